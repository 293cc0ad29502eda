#pragma once
// The pieces of the CBF-QP safety filter (cbf_qp.hpp, whose file comment gives every
// formula): the contact frames' kinematics they all read, the tracking cost, the contact-
// consistency rows, the joint bounds and one function per barrier family (foothold region,
// swing clearance, leg/terrain collision, support polygon). Each writes its part of a
// DenseQpProblem in place at a given row and returns how many rows it wrote; CbfQpFilter::
// filter assembles them. None allocates, locks or throws.
//
// A barrier row is C_r a >= l_r (u_r = +inf) on the generalized acceleration a, the
// second-order CBF condition h'' + 2 gamma h' + gamma^2 h >= 0 of its h.
#include <Eigen/Core>
#include <vector>

#include "rollstep/centroidal/robot.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/control/dense_qp.hpp"
#include "rollstep/model/data.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::control {

struct AccelerationTargets;

/// The contact frames' origins at a state (q, v), world axes, sized once for a robot.
struct ContactKinematics {
  explicit ContactKinematics(const centroidal::CentroidalRobot& robot);

  Eigen::MatrixXd jacobian;  ///< 3 nc x nv: rows 3 i .. 3 i + 2, J_i (linear, world)
  Eigen::Matrix3Xd position, velocity;
  Eigen::Matrix3Xd drift;    ///< classical acceleration at a = 0 (dJ_i v)
  Eigen::Matrix3Xd lateral;  ///< e_lat of each drive wheel
  /// a_lat = e_lat . (J a) + lateral_drift: e_lat . dJ v - yaw_rate (e_fwd . v_i).
  Eigen::VectorXd lateral_drift;
  /// Spatial acceleration of each body at a = 0 (world axes, at the world origin).
  std::vector<Eigen::Matrix<double, 6, 1>> body_drift;
  Eigen::MatrixXd frame_jacobian;  ///< 6 x nv scratch

  auto footJacobian(int i) const { return jacobian.middleRows<3>(3 * i); }
};

/// Forward kinematics at (q, v) into `data` (placements, body velocities) and every field
/// of `out`.
void computeContactKinematics(const centroidal::CentroidalRobot& robot, model::Data& data,
                              const Eigen::Ref<const Eigen::VectorXd>& q,
                              const Eigen::Ref<const Eigen::VectorXd>& v, ContactKinematics& out);

/// H and g (current size nv) of the tracking cost: base, joints, every foot, damping.
void writeTrackingCost(const CbfQpSettings& s, const ContactKinematics& kin,
                       const AccelerationTargets& targets, int nj, DenseQpProblem& qp);

/// Contact consistency of the stance feet of `mode`: kept rows as equalities a_row =
/// -k v_row from equality row 0 on, freed rows (side-by-side rule) added to the cost.
/// The first row of a foot is along its terrain normal (column i of `normals`, 3 x nc;
/// +z for every foot when null): a wheel rolls along a slope. `lateral_rows`: drive
/// wheels have their lateral rows (no skid steering). `row` is a 1 x nv scratch. Returns
/// the equality rows written.
int writeContactRows(const centroidal::CentroidalRobot& robot, const CbfQpSettings& s,
                     const ContactKinematics& kin, int mode, bool lateral_rows,
                     Eigen::RowVectorXd& row, DenseQpProblem& qp,
                     const Eigen::Matrix3Xd* normals = nullptr);

/// Joint position (second-order) and velocity (first-order) barriers as bounds on the
/// joint accelerations; the velocity interval wins a conflict. `lower`, `upper`: position
/// limits with the margin (+-inf: none); `vmax`: scaled velocity limits (+inf: none).
/// The base's bounds are unbounded.
void writeJointBounds(const Eigen::Ref<const Eigen::VectorXd>& q,
                      const Eigen::Ref<const Eigen::VectorXd>& v, const Eigen::VectorXd& lower,
                      const Eigen::VectorXd& upper, const Eigen::VectorXd& vmax,
                      double position_gamma, double velocity_gamma, DenseQpProblem& qp);

/// Foot i inside `region`: one row per edge, h = A_e . (x_i, y_i) + b_e.
int writeRegionRows(const planning::ConvexRegion& region, const ContactKinematics& kin, int i,
                    double gamma, DenseQpProblem& qp, int row);

/// Swing wheel i above the plane of the region of `terrain` under it (z = 0 without one):
/// h = z_i - contact_offset - H(x_i, y_i) - clearance. One row.
int writeClearanceRow(const planning::TerrainModel& terrain, double contact_offset,
                      double clearance, const ContactKinematics& kin, int i, double gamma,
                      DenseQpProblem& qp, int row);

/// Whether prism j of `solids` is an obstacle of foot i: nearer than `range` and neither
/// its support prism (`support_prism`, or the prism under the wheel for -1) nor level with
/// it.
bool isCollisionObstacle(const planning::TerrainModel& solids, int j, const Eigen::Vector3d& p,
                         int support_prism, double contact_offset, double range);

/// Foot i clear of `prism`: h = d(p_i) - contact_offset - clearance with d the smoothed
/// distance (barriers.hpp, `sharpness`). One row.
int writeCollisionRow(const planning::ConvexRegion& prism, double contact_offset, double clearance,
                      double sharpness, const ContactKinematics& kin, int i, double gamma,
                      DenseQpProblem& qp, int row);

/// The support polygon: the convex hull (convexHull) of the (x, y) of the feet of
/// `support_mask`. `xy` gets those points, `feet` the foot of each, `hull` the indices into
/// both of the hull's vertices, counter-clockwise (nc, nc and nc + 1 entries, sized by the
/// caller). Returns the hull's size (< 3: no polygon).
int supportHull(const ContactKinematics& kin, int nc, int support_mask,
                std::vector<Eigen::Vector2d>& xy, std::vector<int>& feet, std::vector<int>& hull);

/// The COM inside the support polygon (supportHull's `feet` and `hull`, hull_size >= 3)
/// with a margin: one row per edge, h = n . (c - m) - margin. Reads the body velocities of
/// `data` (computeContactKinematics at q before) and computes its COM and COM Jacobian at q.
/// Returns the rows written.
int writeSupportRows(const model::Model& model, model::Data& data,
                     const Eigen::Ref<const Eigen::VectorXd>& q, const ContactKinematics& kin,
                     const std::vector<int>& feet, const std::vector<int>& hull, int hull_size,
                     double margin, double gamma, DenseQpProblem& qp, int row);

}  // namespace rollstep::control
