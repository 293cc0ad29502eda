#pragma once
// Contact-aided invariant extended Kalman filter with rolling wheel contacts (paper Sec.
// 3.3: "a variant of the extended Kalman filter" of Hartley et al. 2020), robot-agnostic:
// any floating-base model, any set of contact frames, each a point foot, a drive wheel or
// an omni wheel.
//
// State: X = (R, v, p) in SE_2(3) (base orientation base->world, base velocity and position
// in the world) and the IMU biases (b_g, b_a) in R^6. Error: right-invariant on the group,
// X = exp(xi) X_hat, xi = (phi, dv, dp) in world axes; b = b_hat + db. Covariance P is 15 x
// 15 in the order (phi, dv, dp, db_g, db_a). The IMU is at the base origin, axes of the base.
//
// Propagation (IMU, "imperfect" IEKF: the biases break the group-affine property only
// through their coupling): with w = gyro - b_g, a = accel - b_a,
//   R+ = R exp(w dt), v+ = v + (R a + g) dt, p+ = p + v dt + (R a + g) dt^2 / 2,
//   d/dt xi = A xi - Ad_X (n_g + db_g, n_a + db_a, 0), A = [0 0 0; g^ 0 0; 0 I 0],
//   P+ = Phi P Phi' + Phi Q Phi' dt, Phi = I + A dt (first order at 1 kHz).
//
// Contacts (leg kinematics through the model layer, from the joint encoders): a stance
// contact gives a measurement of the base velocity in the base frame, R' v. With p_c the
// contact frame's origin (the wheel centre) in the base frame, v_rel and w_rel its velocity
// and angular velocity relative to the base (J(q_J) v_J), and n the ground normal (world z)
// in the base frame:
//  - point foot (a foot that does not roll): the foot is still,
//      R' v = -(w x p_c + v_rel);
//  - drive wheel (rolls about its axle a, the contact frame's y axis, cannot slide): the
//    wheel's contact point with the ground is still, so the centre moves with the wheel's
//    rolling velocity w_wheel x (r n) (r: the effective rolling radius), where w_wheel = w + w_rel
//    + s a is the wheel's absolute angular velocity (s: the wheel encoder's speed relative to its
//    shank, r: the wheel radius):
//      R' v = -(w x p_c + v_rel) + (w + w_rel + s a) x (r n);
//  - omni wheel (a passive wheel that rolls freely in any direction): only the centre's
//    velocity along the normal is known (it keeps its height above the ground); its
//    horizontal velocity is anything, so the two horizontal rows are not measured:
//      n' R' v = -n' (w x p_c + v_rel).
// The measurement is linear in the invariant error: innovation = R_hat' dv +
// (p_c - r n) x db_g (the contact point's lever arm picks up the gyro bias, which is what
// makes b_g observable), H = [0, R_hat', 0, (p_c - r n)^, 0].
// Ground height (when the input gives it, from a map): a stance contact's ground point
// p + R (p_c - r n) has the map's height, one row e_z' (...) with H = e_z' [-(w)^, 0, I, 0, 0],
// w = p_hat + R_hat p_c. Velocity measurements alone leave the height unobservable, and the
// trot's stance transients bias the vertical velocity: without it the height estimate
// drifted up by ~2.5 mm/s and the body walked ever lower.
// The naive "stance foot is fixed" model (settings.rolling = false: every contact a point
// foot at its wheel centre) is kept to show what it costs: a rolling robot looks still.
//
// Robustness: IMU samples that are not finite or beyond the configured ranges are rejected
// (the last good sample is used), so are encoder samples (no contact update that tick);
// each contact innovation passes a chi-square gate (a stuck contact flag, slip), with a
// recovery rule when every stance contact that measures the horizontal velocity (every
// stance contact if only omni wheels stand) has been rejected for gate_recovery_ticks: the
// velocity covariance gets the initial velocity variance added and the measurements pass. Every
// rejection is counted and recorded in an event ring (time and kind).
//
// Real-time contract: tick() never allocates, locks or throws; the workspace is sized at
// construction (at most kMaxContacts contacts).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "rollstep/common/enum_names.hpp"
#include "rollstep/model/model.hpp"

namespace rollstep::model {
struct Data;
}

namespace rollstep::estimation {

inline constexpr int kMaxContacts = 8;
inline constexpr int kErrorDim = 15;

enum class ContactKind { Point, DriveWheel, OmniWheel };
constexpr std::array<EnumName<ContactKind>, 3> enumNames(ContactKind) {
  return {{{ContactKind::Point, "point"},
           {ContactKind::DriveWheel, "drive_wheel"},
           {ContactKind::OmniWheel, "omni_wheel"}}};
}
const char* toString(ContactKind kind);

struct ContactSpec {
  std::string frame;  ///< a frame of the model (the wheel centre for a wheel)
  ContactKind kind = ContactKind::Point;
  double radius = 0.0;  ///< [m] wheel radius (0 for a point foot)
};

/// The filter's tuning (robots/tachyon3/estimation.yaml documents every key and its
/// default).
struct InekfSettings {
  double gravity = 9.81;  ///< [m/s^2] along world -z
  // imu:
  double gyro_noise = 2.4e-4;       ///< [rad/s/sqrt(Hz)]
  double accel_noise = 2.0e-3;      ///< [m/s^2/sqrt(Hz)]
  double gyro_bias_walk = 2.0e-5;   ///< [rad/s^2/sqrt(Hz)]
  double accel_bias_walk = 3.0e-4;  ///< [m/s^3/sqrt(Hz)]
  // contacts:
  bool rolling = true;                   ///< rolling-contact model (false: naive fixed feet)
  double contact_velocity_noise = 0.05;  ///< [m/s] std dev: slip, compliance, model error
  double joint_velocity_noise = 0.01;    ///< [rad/s or m/s] std dev of the drives' velocities
  double wheel_velocity_noise = 0.02;    ///< [rad/s] std dev of the wheel encoders' speeds
  /// [m] nominal minus effective rolling radius of the wheels (a loaded tyre, or MuJoCo's
  /// soft contact, rolls on a smaller radius than its nominal one)
  double rolling_radius_offset = 0.0;
  double height_noise = 0.01;    ///< [m] std dev of a stance contact's ground height (a map's)
  double gate_3dof = 16.27;      ///< chi-square gate of a 3-row innovation (0: off)
  double gate_1dof = 10.83;      ///< ... of a 1-row innovation (0: off)
  int gate_recovery_ticks = 50;  ///< all stance rejected this long: accept again
  // initial (standard deviations):
  double initial_orientation = 0.01;  ///< [rad]
  double initial_velocity = 0.05;     ///< [m/s]
  double initial_position = 0.01;     ///< [m]
  double initial_gyro_bias = 0.01;    ///< [rad/s]
  double initial_accel_bias = 0.1;    ///< [m/s^2]
  // limits (a sample beyond them is rejected):
  double max_angular_rate = 30.0;    ///< [rad/s]
  double max_acceleration = 160.0;   ///< [m/s^2]
  double max_joint_velocity = 50.0;  ///< [rad/s or m/s]
  double joint_limit_margin = 0.2;   ///< [rad or m] beyond the model's position limits
  double max_wheel_speed = 200.0;    ///< [rad/s]
  double max_dt = 0.05;              ///< [s] a longer gap is not integrated
};

/// Reads estimation.yaml text (robots/tachyon3/estimation.yaml) (sections imu, contacts, initial,
/// limits and the top-level gravity); absent keys keep their defaults; errors name the file, line
/// and key.
InekfSettings parseInekfSettings(const std::string& yaml_text, const std::string& source);
InekfSettings loadInekfSettings(const std::string& yaml_file);
std::string toYaml(const InekfSettings& settings);

/// One sample of the sensors, in the model's conventions.
struct EstimatorInput {
  double time = 0.0;                                  ///< [s]
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();     ///< [rad/s] base frame
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();    ///< [m/s^2] specific force, base frame
  Eigen::VectorXd joint_position;                     ///< nj, model joint order
  Eigen::VectorXd joint_velocity;                     ///< nj
  std::array<double, kMaxContacts> wheel_velocity{};  ///< per contact [rad/s] (drive wheels)
  std::array<bool, kMaxContacts> contact{};           ///< per contact: stance flag
  /// Per contact: the ground's height [m] (world z) under it, from a map, or NaN when
  /// unknown (not used).
  std::array<double, kMaxContacts> ground_height = unknownHeights();
  static std::array<double, kMaxContacts> unknownHeights() {
    std::array<double, kMaxContacts> a{};
    a.fill(std::numeric_limits<double>::quiet_NaN());
    return a;
  }
};

enum class EstimatorEvent : std::uint8_t {
  ImuRejected,      ///< gyro/accel not finite or out of range: last good sample used
  EncoderRejected,  ///< joint or wheel sample not finite or out of range: no update
  TimeRejected,     ///< time not finite, backwards, or a gap beyond max_dt
  ContactRejected,  ///< a stance contact's innovation failed the gate
  GateRecovered,    ///< every stance contact rejected too long: measurements accepted
};
constexpr std::array<EnumName<EstimatorEvent>, 5> enumNames(EstimatorEvent) {
  return {{{EstimatorEvent::ImuRejected, "imu_rejected"},
           {EstimatorEvent::EncoderRejected, "encoder_rejected"},
           {EstimatorEvent::TimeRejected, "time_rejected"},
           {EstimatorEvent::ContactRejected, "contact_rejected"},
           {EstimatorEvent::GateRecovered, "gate_recovered"}}};
}
const char* toString(EstimatorEvent event);

struct EstimatorCounters {
  std::uint64_t ticks = 0;
  std::uint64_t imu_rejected = 0;
  std::uint64_t encoder_rejected = 0;
  std::uint64_t time_rejected = 0;
  std::uint64_t contacts_used = 0;      ///< contact measurements applied
  std::uint64_t contacts_rejected = 0;  ///< failed the gate
  std::uint64_t gate_recoveries = 0;
};

struct EventRecord {
  double time = 0.0;
  EstimatorEvent event = EstimatorEvent::ImuRejected;
  int contact = -1;  ///< the contact concerned, or -1
};

class InvariantEkf {
 public:
  using Matrix15 = Eigen::Matrix<double, kErrorDim, kErrorDim>;
  static constexpr int kEventRing = 64;

  /// Throws std::invalid_argument for a model without a free-flyer base, an unknown frame,
  /// too many contacts (> kMaxContacts), a wheel without a positive radius, or settings that
  /// are not finite or out of range.
  InvariantEkf(const model::Model& model, std::vector<ContactSpec> contacts,
               const InekfSettings& settings);
  ~InvariantEkf();
  InvariantEkf(const InvariantEkf&) = delete;
  InvariantEkf& operator=(const InvariantEkf&) = delete;

  /// Restarts at a known pose and velocity (world), biases zero, covariance from the
  /// settings' initial standard deviations; counters and events kept.
  void reset(double time, const Eigen::Quaterniond& orientation, const Eigen::Vector3d& position,
             const Eigen::Vector3d& velocity) noexcept;
  /// One filter step: propagate with the IMU to input.time, then the contact updates.
  /// Returns false if the sample was (partly) rejected. Never allocates or throws.
  bool tick(const EstimatorInput& input) noexcept;

  /// An input sized for this filter's model (joint vectors of nj entries).
  EstimatorInput makeInput() const;

  double time() const { return time_; }
  Eigen::Quaterniond orientation() const { return Eigen::Quaterniond(R_).normalized(); }
  const Eigen::Matrix3d& rotation() const { return R_; }
  const Eigen::Vector3d& velocity() const { return v_; }  ///< world
  const Eigen::Vector3d& position() const { return p_; }  ///< world
  const Eigen::Vector3d& gyroBias() const { return bg_; }
  const Eigen::Vector3d& accelBias() const { return ba_; }
  /// The last gyro sample less the bias estimate [rad/s] (base frame).
  const Eigen::Vector3d& angularVelocity() const { return omega_; }
  /// Covariance of the right-invariant error (phi, dv, dp, db_g, db_a).
  const Matrix15& covariance() const { return P_; }
  /// The last joint sample that was accepted (model order).
  const Eigen::VectorXd& jointPosition() const { return qj_; }
  const Eigen::VectorXd& jointVelocity() const { return vj_; }
  /// World position of contact i's ground point at the last update it was in stance (the
  /// base position before).
  const Eigen::Vector3d& contactPoint(int i) const {
    return contact_point_[static_cast<std::size_t>(i)];
  }
  bool finite() const;

  const EstimatorCounters& counters() const { return counters_; }
  /// The last min(events(), kEventRing) events, oldest first via event(i).
  std::uint64_t events() const { return events_; }
  const EventRecord& event(std::uint64_t i) const { return ring_[i % kEventRing]; }
  const std::vector<ContactSpec>& contacts() const { return contacts_; }
  const InekfSettings& settings() const { return settings_; }
  int nj() const { return nj_; }

 private:
  void propagate(double dt) noexcept;
  bool encodersValid(const EstimatorInput& in) const noexcept;
  void update(const EstimatorInput& in) noexcept;
  void record(double t, EstimatorEvent e, int contact) noexcept;

  model::Model model_;
  std::unique_ptr<model::Data> data_;
  std::vector<ContactSpec> contacts_;
  std::vector<model::FrameIndex> frames_;
  InekfSettings settings_;
  int nj_ = 0;
  Eigen::Vector3d gravity_;

  double time_ = 0.0;
  bool started_ = false;
  Eigen::Matrix3d R_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d v_ = Eigen::Vector3d::Zero(), p_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d bg_ = Eigen::Vector3d::Zero(), ba_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d omega_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_last_ = Eigen::Vector3d::Zero(), accel_last_ = Eigen::Vector3d::Zero();
  bool imu_valid_ = false;
  Matrix15 P_ = Matrix15::Identity();
  Eigen::VectorXd q_, qj_, vj_;
  Eigen::MatrixXd J_;  // 6 x nv frame Jacobian
  int all_rejected_ticks_ = 0;
  std::array<Eigen::Vector3d, kMaxContacts> contact_point_{};

  EstimatorCounters counters_;
  std::array<EventRecord, kEventRing> ring_{};
  std::uint64_t events_ = 0;
};

}  // namespace rollstep::estimation
