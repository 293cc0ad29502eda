#pragma once
// The robot description the centroidal OCP terms share: a free-flyer model, its contact
// points (in mode-mask bit order), which feet stand side by side, and the index layout of
// the full-centroidal state and input (DESIGN.md section 2, paper Sec. 2.2).
//
// Layout (binding for every term of the centroidal layer):
//   state   x  = [p (3), quaternion x y z w (4), q_J (nj), h (6)]          size nx()  = 13 + nj
//   tangent dx = [rho (3), theta (3), dq_J (nj), dh (6)]                     size ndx() = 12 + nj
//     (rho, theta: SE(3) right/local perturbation, the model's dq_b; h = [linear; angular
//      about the COM], world frame)
//   input   u  = [v_J (nj), f_0 (3), ..., f_{nc-1} (3)]                     size nu()  = nj + 3 nc
//     (f_i: world-frame force acting ON the robot at contact i)
//
// Contact point: contact i's force acts at p_i - contact_offset * e_z, p_i the world
// position of its frame's origin. With the frames at the wheel centres, contact_offset is
// the wheel radius: velocity constraints use the wheel centre (a rolling wheel's centre
// moves parallel to the ground), the momentum equation uses the ground contact point as
// the lever arm.
//
// Side-by-side rule (paper Sec. 2.3): for each pair {a, b} of side_pairs, when BOTH a and b
// are in stance, only the FIRST of the pair (a) keeps its stance velocity constraints
// (z-velocity and, for a drive wheel, lateral velocity); b keeps none. When only one of
// them is in stance, that one keeps its constraints. A contact belongs to at most one pair.
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "rollstep/model/model.hpp"
#include "rollstep/ocp/state_space.hpp"

namespace rollstep::centroidal {

/// One contact point of the robot.
struct ContactDescription {
  std::string frame;         ///< model frame (its origin is the constrained foot point)
  bool drive_wheel = false;  ///< true: no lateral velocity in the foot's yaw frame
};

/// Largest number of contacts (mode masks are int bit sets, planning::kMaxFeet).
inline constexpr int kMaxContacts = 16;

class CentroidalRobot {
 public:
  /// Throws std::invalid_argument naming the value for: a null or non-free-flyer model,
  /// no contacts or more than kMaxContacts, an unknown or repeated frame, a pair index out
  /// of range, a pair of a contact with itself, a contact in two pairs, a negative or
  /// non-finite contact_offset [m].
  CentroidalRobot(std::shared_ptr<const model::Model> model,
                  std::vector<ContactDescription> contacts,
                  std::vector<std::array<int, 2>> side_pairs, double contact_offset);

  const model::Model& model() const { return *model_; }
  const std::shared_ptr<const model::Model>& modelPtr() const { return model_; }
  int nc() const { return static_cast<int>(contacts_.size()); }
  int nj() const { return model_->nj; }
  int nq() const { return model_->nq; }  ///< 7 + nj
  int nv() const { return model_->nv; }  ///< 6 + nj
  int nx() const { return 7 + nj() + 6; }
  int ndx() const { return 12 + nj(); }
  int nu() const { return nj() + 3 * nc(); }
  /// Names of the tangent coordinates ("base x", "base rot z", "<joint> position",
  /// "momentum angular y") and of the inputs ("<joint> velocity", "<frame> force z"), in
  /// the layout above (OptimalControlProblem::setCoordinateNames).
  std::vector<std::string> tangentNames() const;
  std::vector<std::string> inputNames() const;
  const std::vector<model::FrameIndex>& frameIds() const { return frame_ids_; }
  const ContactDescription& contact(int i) const { return contacts_[static_cast<size_t>(i)]; }
  const std::vector<std::array<int, 2>>& sidePairs() const { return side_pairs_; }
  /// The other contact of i's side pair, -1 if i is in none.
  int partnerOf(int i) const { return partner_[static_cast<size_t>(i)]; }
  double contactOffset() const { return contact_offset_; }
  double mass() const { return model_->totalMass; }
  /// SE(3) x R^(nj + 6).
  const std::shared_ptr<const ocp::SE3xEuclideanSpace>& space() const { return space_; }

  /// True if contact i is in stance in `mode` and keeps its stance velocity constraints
  /// under the side-by-side rule (see the file comment).
  bool keepsVelocityConstraints(int mode, int i) const;
  static bool inStance(int mode, int i) { return ((mode >> i) & 1) != 0; }

  /// Body carrying contact i's frame.
  int contactBody(int i) const { return bodies_[static_cast<size_t>(i)]; }
  /// Velocity columns (0..nv-1) that move contact i's body: the 6 base columns, then its
  /// ancestor joints' columns in increasing order. Every other column of its Jacobians is 0.
  const std::vector<int>& supportColumns(int i) const { return support_[static_cast<size_t>(i)]; }

  // Index helpers (see the layout above).
  int stateJointIndex() const { return 7; }            ///< q_J in x
  int stateMomentumIndex() const { return 7 + nj(); }  ///< h in x
  int tangentJointIndex() const { return 6; }          ///< dq_J in dx
  int tangentMomentumIndex() const { return 6 + nj(); }
  int inputJointVelocityIndex() const { return 0; }  ///< v_J in u
  int inputForceIndex(int i) const { return nj() + 3 * i; }

 private:
  std::shared_ptr<const model::Model> model_;
  std::vector<ContactDescription> contacts_;
  std::vector<std::array<int, 2>> side_pairs_;
  double contact_offset_;
  std::vector<model::FrameIndex> frame_ids_;
  std::vector<int> partner_;
  std::vector<int> second_;  ///< 1 for the second contact of a pair
  std::vector<int> bodies_;
  std::vector<std::vector<int>> support_;
  std::shared_ptr<const ocp::SE3xEuclideanSpace> space_;
};

}  // namespace rollstep::centroidal
