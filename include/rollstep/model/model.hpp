#pragma once
// Immutable rigid-body tree (the robot), Pinocchio style: `Model` describes the robot,
// `Data` (data.hpp) holds every workspace, algorithms are free functions
// `computeX(const Model&, Data&, ...)` that never allocate.
//
// Conventions (binding for the whole project):
//  - Bodies are the rigid bodies left after fixed joints are merged into their parent.
//    Body 0 is the root (URDF root link); bodies are numbered in depth-first order, so the
//    subtree of body i is the index range [i, bodies[i].subtreeEnd).
//  - Free-flyer root (RootJoint::FreeFlyer): q = [p (3), quat (x, y, z, w) (4), q_J],
//    v = [v_lin (3), omega (3), v_J] with the base twist in the base LOCAL frame. The
//    tangent perturbation of q is dq = [dq_b (6, local, SE(3) right-plus), dq_J]; every
//    "derivative w.r.t. q" is w.r.t. dq. Fixed root (RootJoint::Fixed): q = q_J, v = v_J.
//  - Joint j (1 DoF, revolute or prismatic; URDF continuous = revolute without limits) has
//    configuration index q[bodies[i].idxQ] and velocity index v[bodies[i].idxV]; joints are in
//    depth-first order of the URDF tree, like Pinocchio.
//  - The quaternion in q must have unit norm (integrate() keeps it so); it is not
//    renormalised by the algorithms.
//  - Units: SI (m, rad, kg, N, s). Gravity is (0, 0, -9.81) m/s^2 unless changed.
#include <Eigen/Core>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "rollstep/lie/se3.hpp"

namespace rollstep::model {

using FrameIndex = int;
using Vector6d = lie::Vector6d;
using Matrix6Xd = Eigen::Matrix<double, 6, Eigen::Dynamic>;

enum class JointType { Revolute, Prismatic };
enum class RootJoint { FreeFlyer, Fixed };

/// Frame in which a velocity or Jacobian is expressed (Pinocchio's meaning):
///  LOCAL: the frame's own axes, linear velocity of the frame origin;
///  WORLD: world axes, spatial velocity at the world origin;
///  LOCAL_WORLD_ALIGNED: world axes, linear velocity of the frame origin.
/// Six-vectors are always [linear (3); angular (3)].
enum class ReferenceFrame { LOCAL, WORLD, LOCAL_WORLD_ALIGNED };

/// A rigid body after merging fixed joints, with the joint that connects it to its parent.
struct Body {
  std::string name;    ///< URDF link carrying the body frame (= its joint frame)
  int parent = -1;     ///< parent body, -1 for the root
  int subtreeEnd = 0;  ///< one past the last body of this body's subtree
  // Joint (unused for the root).
  std::string joint;  ///< URDF joint name
  JointType type = JointType::Revolute;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();              ///< unit axis in this body's frame
  Eigen::Matrix3d jointRotation = Eigen::Matrix3d::Identity();  ///< joint frame in parent body
  Eigen::Vector3d jointTranslation = Eigen::Vector3d::Zero();   ///< (at joint position 0)
  int idxQ = -1;                                                ///< index in q (-1 for the root)
  int idxV = -1;                                                ///< index in v (-1 for the root)
  // Inertia of the body including merged fixed children, in the body frame.
  double mass = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();      ///< centre of mass
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();  ///< rotational inertia about com
  double subtreeMass = 0.0;
  // Precomputed for the joint rotation R(q) = I + sin(q) K + (1 - cos(q)) K^2, K = hat(axis).
  Eigen::Matrix3d axisHat = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d axisHat2 = Eigen::Matrix3d::Zero();
};

/// A named frame rigidly attached to a body (one per URDF link, merged ones included).
struct Frame {
  std::string name;
  int body = 0;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< placement in the body frame
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
};

struct Model {
  std::string name;
  RootJoint root = RootJoint::FreeFlyer;
  int nq = 0;      ///< configuration size
  int nv = 0;      ///< tangent / velocity size
  int nj = 0;      ///< number of 1-DoF joints
  int nqBase = 0;  ///< 7 for a free flyer, 0 for a fixed root
  int nvBase = 0;  ///< 6 for a free flyer, 0 for a fixed root
  std::vector<Body> bodies;
  std::vector<Frame> frames;
  std::vector<std::string> jointNames;  ///< joint j <-> q[nqBase + j], v[nvBase + j]
  Eigen::VectorXd lowerPositionLimit;   ///< nj, -inf for continuous joints
  Eigen::VectorXd upperPositionLimit;   ///< nj, +inf for continuous joints
  Eigen::VectorXd velocityLimit;        ///< nj
  Eigen::VectorXd effortLimit;          ///< nj
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  double totalMass = 0.0;

  int nbodies() const { return static_cast<int>(bodies.size()); }
  int nframes() const { return static_cast<int>(frames.size()); }
  bool hasFreeFlyer() const { return root == RootJoint::FreeFlyer; }
  /// Frame index by name; throws std::out_of_range naming the frame if absent.
  FrameIndex getFrameId(const std::string& frame_name) const;
  bool existFrame(const std::string& frame_name) const;
  /// Joint index j (0..nj-1) by name; throws std::out_of_range if absent.
  int getJointId(const std::string& joint_name) const;
  /// Body owning velocity column `col`.
  int bodyOfVelocityIndex(int col) const { return col < nvBase ? 0 : col - nvBase + 1; }
};

/// Sanity bounds of the URDF loader (anything beyond is a typo, not a robot).
constexpr double kUrdfMaxMass = 1e5;            ///< [kg] mass of one link
constexpr double kUrdfMaxInertia = 1e5;         ///< [kg m^2] entries of one link's inertia
constexpr double kUrdfMaxDistance = 1e3;        ///< [m] |xyz| of a joint or inertial origin
constexpr double kUrdfInertiaTolerance = 1e-6;  ///< relative, of the largest principal moment
constexpr int kUrdfMaxXmlDepth = 64;            ///< element nesting of the XML text

/// Loads a URDF file (urdfdom). Fixed joints are merged into their parent body.
/// The file is read with rollstep::readTextFile (a directory, FIFO, device or a file above
/// 64 MiB is refused before it is opened). Throws rollstep::model::ModelError, its message
/// starting with "URDF file '<path>': " and naming the element (link or joint), the value and
/// the valid range, for:
///  - unparsable XML (urdfdom's own message), elements nested more than kUrdfMaxXmlDepth deep;
///  - a missing link, an unsupported joint type (floating, planar), a link with two parents
///    or not connected to the root (kinematic loop), several roots;
///  - a joint or inertial origin that is not finite or farther than kUrdfMaxDistance;
///  - a joint axis that is zero or not finite;
///  - joint limits: lower > upper or not finite (revolute, prismatic), a negative or
///    non-finite velocity or effort (0 means "no limit", as before); negative or non-finite
///    <dynamics> damping or friction;
///  - an <inertial> whose mass is not in (0, kUrdfMaxMass] (NaN included; a massless link
///    has no <inertial> element: such links, e.g. frames merged by fixed joints, are fine),
///    or whose inertia is not finite, has an entry above kUrdfMaxInertia, is not positive
///    semidefinite or breaks the triangle inequality of its principal moments
///    (A + B >= C; tolerance kUrdfInertiaTolerance of the largest); a point mass (zero
///    inertia) is a valid link;
///  - a total mass of zero; with a free-flyer root, a whole-robot rotational inertia about
///    the centre of mass (neutral configuration) that is not positive definite.
/// The tree is walked with an explicit stack: a chain of any length is fine.
Model buildModelFromUrdfFile(const std::string& path, RootJoint root = RootJoint::FreeFlyer);
/// Same from an XML string (messages without the file name).
Model buildModelFromUrdfString(const std::string& xml, RootJoint root = RootJoint::FreeFlyer);

/// Error raised while building a Model.
class ModelError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Neutral configuration: zero position, identity quaternion, zero joints.
Eigen::VectorXd neutralConfiguration(const Model& model);
/// qout = q (+) v: SE(3) right-plus on the free flyer, addition on the joints.
/// `qout` may alias `q`. Allocation-free.
void integrate(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q,
               const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::Ref<Eigen::VectorXd> qout);
/// dv = q1 (-) q0 (Pinocchio's difference(q0, q1)). Allocation-free.
void difference(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q0,
                const Eigen::Ref<const Eigen::VectorXd>& q1, Eigen::Ref<Eigen::VectorXd> dv);

}  // namespace rollstep::model
