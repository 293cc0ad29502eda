#include "rollstep/estimation/invariant_ekf.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <stdexcept>

#include "rollstep/common/number_text.hpp"
#include "rollstep/common/settings_table.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/lie/so3.hpp"
#include "rollstep/model/data.hpp"
#include "rollstep/model/kinematics.hpp"

namespace rollstep::estimation {

const char* toString(ContactKind kind) { return enumName(kind); }

const char* toString(EstimatorEvent event) { return enumName(event); }

namespace {

using Matrix3 = Eigen::Matrix3d;
using Vector3 = Eigen::Vector3d;
constexpr int kMaxRows = 4 * kMaxContacts;  // 3 velocity rows + 1 height row each
using RowsMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, kErrorDim, Eigen::RowMajor, kMaxRows, kErrorDim>;
using SquareMax = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxRows, kMaxRows>;
using VectorMax = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxRows, 1>;
using GainMatrix = Eigen::Matrix<double, kErrorDim, Eigen::Dynamic, 0, kErrorDim, kMaxRows>;

// The settings' sections; `rolling` and gate_recovery_ticks are read as numbers.
// The keys, in robots/<robot>/estimation.yaml's order, with their ranges. `rolling` is
// written 1 or 0 (the file's spelling).
const settings::Table<InekfSettings>& inekfTable() {
  using S = InekfSettings;
  using settings::Range;
  using T = settings::Table<S>;
  constexpr double kBig = 1e6;
  const auto rolling = [](const yaml::Node& v, S& s, settings::Reader& r, const std::string& path) {
    if (v.isNull()) r.fail(v, path + ": no value");
    const double x = settings::detail::readNumber(v, Range::closed(0.0, 1.0), r, path);
    if (x != 0.0 && x != 1.0) r.fail(v, path + ": must be 0 or 1");
    s.rolling = x == 1.0;
  };
  static const T table =
      T().field("gravity", &S::gravity, "m/s^2", Range::closed(0.0, 100.0))
          .group("imu",
                 T().field("gyro_noise", &S::gyro_noise, "rad/s/sqrt(Hz)", Range::closed(1e-9, 1.0))
                     .field("accel_noise", &S::accel_noise, "m/s^2/sqrt(Hz)",
                            Range::closed(1e-9, 10.0))
                     .field("gyro_bias_walk", &S::gyro_bias_walk, "rad/s^2/sqrt(Hz)",
                            Range::closed(0.0, 1.0))
                     .field("accel_bias_walk", &S::accel_bias_walk, "m/s^3/sqrt(Hz)",
                            Range::closed(0.0, 10.0)))
          .group(
              "contacts",
              T().custom("rolling", rolling,
                         [](const S& s, const std::string&) {
                           return std::string(s.rolling ? " 1" : " 0");
                         })
                  .field("velocity_noise", &S::contact_velocity_noise, "m/s",
                         Range::closed(1e-6, 10.0))
                  .field("joint_velocity_noise", &S::joint_velocity_noise, "rad/s or m/s",
                         Range::closed(0.0, 10.0))
                  .field("wheel_velocity_noise", &S::wheel_velocity_noise, "rad/s",
                         Range::closed(0.0, 10.0))
                  .field("rolling_radius_offset", &S::rolling_radius_offset, "m",
                         Range::closed(-1.0, 1.0))
                  .field("height_noise", &S::height_noise, "m", Range::closed(1e-6, 10.0))
                  .field("gate_3dof", &S::gate_3dof, "", Range::closed(0.0, kBig))
                  .field("gate_1dof", &S::gate_1dof, "", Range::closed(0.0, kBig))
                  .field("gate_recovery_ticks", &S::gate_recovery_ticks, "", Range::closed(1, 1e9)))
          .group(
              "initial",
              T().field("orientation", &S::initial_orientation, "rad", Range::closed(1e-9, 10.0))
                  .field("velocity", &S::initial_velocity, "m/s", Range::closed(1e-9, 100.0))
                  .field("position", &S::initial_position, "m", Range::closed(1e-9, 1e6))
                  .field("gyro_bias", &S::initial_gyro_bias, "rad/s", Range::closed(1e-9, 10.0))
                  .field("accel_bias", &S::initial_accel_bias, "m/s^2", Range::closed(1e-9, 100.0)))
          .group(
              "limits",
              T().field("max_angular_rate", &S::max_angular_rate, "rad/s", Range::closed(0.0, kBig))
                  .field("max_acceleration", &S::max_acceleration, "m/s^2",
                         Range::closed(0.0, kBig))
                  .field("max_joint_velocity", &S::max_joint_velocity, "rad/s or m/s",
                         Range::closed(0.0, kBig))
                  .field("joint_limit_margin", &S::joint_limit_margin, "rad or m",
                         Range::closed(0.0, kBig))
                  .field("max_wheel_speed", &S::max_wheel_speed, "rad/s", Range::closed(0.0, kBig))
                  .field("max_dt", &S::max_dt, "s", Range::closed(1e-6, 10.0)));
  return table;
}

// exp of SE_2(3) applied on the left: X <- exp(xi) X.
void leftCompose(const Eigen::Matrix<double, 9, 1>& xi, Matrix3& R, Vector3& v, Vector3& p) {
  const Vector3 phi = xi.head<3>();
  const Matrix3 dR = lie::expSO3(phi).toRotationMatrix();
  const Matrix3 Jl = lie::leftJacobianSO3(phi);
  R = dR * R;
  v = dR * v + Jl * xi.segment<3>(3);
  p = dR * p + Jl * xi.segment<3>(6);
  // Keep R orthonormal against rounding over long runs.
  const Eigen::Quaterniond q(R);
  R = q.normalized().toRotationMatrix();
}

}  // namespace

InekfSettings parseInekfSettings(const std::string& yaml_text, const std::string& source) {
  return settings::readDocument(yaml_text, inekfTable(), "estimator settings '" + source + "': ");
}

InekfSettings loadInekfSettings(const std::string& yaml_file) {
  return parseInekfSettings(readTextFile(yaml_file, "estimator settings", std::size_t{1} << 20),
                            yaml_file);
}

std::string toYaml(const InekfSettings& settings) { return inekfTable().write(settings); }

InvariantEkf::InvariantEkf(const model::Model& model, std::vector<ContactSpec> contacts,
                           const InekfSettings& settings)
    : model_(model), contacts_(std::move(contacts)), settings_(settings) {
  if (model_.nqBase != 7 || model_.nvBase != 6) {
    throw std::invalid_argument("InvariantEkf: the model needs a free-flyer base");
  }
  if (contacts_.size() > static_cast<std::size_t>(kMaxContacts)) {
    throw std::invalid_argument("InvariantEkf: " + std::to_string(contacts_.size()) +
                                " contacts, at most " + std::to_string(kMaxContacts));
  }
  // The settings through their table's ranges.
  if (const std::optional<settings::Problem> p = inekfTable().check(settings_)) {
    throw std::invalid_argument("InvariantEkf: " + p->path + ": " + p->what);
  }
  for (const ContactSpec& c : contacts_) {
    frames_.push_back(model_.getFrameId(c.frame));  // throws for an unknown frame
    if (c.kind != ContactKind::Point && !(std::isfinite(c.radius) && c.radius > 0.0)) {
      throw std::invalid_argument("InvariantEkf: wheel contact '" + c.frame +
                                  "' needs a positive radius, got " + shortestNumberText(c.radius));
    }
  }
  nj_ = model_.nv - model_.nvBase;
  data_ = std::make_unique<model::Data>(model_);
  q_ = Eigen::VectorXd::Zero(model_.nq);
  q_[6] = 1.0;  // base at the identity: kinematics in the base frame
  qj_ = Eigen::VectorXd::Zero(nj_);
  vj_ = Eigen::VectorXd::Zero(nj_);
  J_ = Eigen::MatrixXd::Zero(6, model_.nv);
  gravity_ = Vector3(0.0, 0.0, -settings_.gravity);
  reset(0.0, Eigen::Quaterniond::Identity(), Vector3::Zero(), Vector3::Zero());
}

InvariantEkf::~InvariantEkf() = default;

EstimatorInput InvariantEkf::makeInput() const {
  EstimatorInput in;
  in.joint_position = Eigen::VectorXd::Zero(nj_);
  in.joint_velocity = Eigen::VectorXd::Zero(nj_);
  return in;
}

void InvariantEkf::reset(double time, const Eigen::Quaterniond& orientation,
                         const Eigen::Vector3d& position,
                         const Eigen::Vector3d& velocity) noexcept {
  time_ = time;
  started_ = false;
  imu_valid_ = false;
  R_ = orientation.normalized().toRotationMatrix();
  v_ = velocity;
  p_ = position;
  bg_.setZero();
  ba_.setZero();
  omega_.setZero();
  all_rejected_ticks_ = 0;
  for (Vector3& c : contact_point_) c = position;
  P_.setZero();
  const auto sq = [](double x) { return x * x; };
  P_.diagonal().segment<3>(0).setConstant(sq(settings_.initial_orientation));
  P_.diagonal().segment<3>(3).setConstant(sq(settings_.initial_velocity));
  P_.diagonal().segment<3>(6).setConstant(sq(settings_.initial_position));
  P_.diagonal().segment<3>(9).setConstant(sq(settings_.initial_gyro_bias));
  P_.diagonal().segment<3>(12).setConstant(sq(settings_.initial_accel_bias));
  // The covariance of the right-invariant error is in world axes: a position known at the
  // origin still carries the orientation's uncertainty times the lever arm (Ad_X).
  Eigen::Matrix<double, 9, 9> ad = Eigen::Matrix<double, 9, 9>::Identity();
  ad.block<3, 3>(3, 0) = lie::hat(v_);
  ad.block<3, 3>(6, 0) = lie::hat(p_);
  P_.topLeftCorner<9, 9>() = ad * P_.topLeftCorner<9, 9>() * ad.transpose();
}

bool InvariantEkf::finite() const {
  return R_.allFinite() && v_.allFinite() && p_.allFinite() && bg_.allFinite() && ba_.allFinite() &&
         P_.allFinite();
}

void InvariantEkf::record(double t, EstimatorEvent e, int contact) noexcept {
  EventRecord& r = ring_[events_ % kEventRing];
  r.time = t;
  r.event = e;
  r.contact = contact;
  ++events_;
}

void InvariantEkf::propagate(double dt) noexcept {
  const Vector3 w = gyro_last_ - bg_;
  const Vector3 a = accel_last_ - ba_;
  const Vector3 acc = R_ * a + gravity_;
  // Noise and bias coupling use the state at the start of the step.
  const Matrix3 R0 = R_;
  const Vector3 v0 = v_, p0 = p_;
  p_ += v_ * dt + 0.5 * acc * dt * dt;
  v_ += acc * dt;
  R_ = R_ * lie::expSO3(w * dt).toRotationMatrix();

  // Phi = I + A dt with A of the right-invariant error and the bias coupling -Ad_X.
  Matrix15 Phi = Matrix15::Identity();
  Phi.block<3, 3>(3, 0) = lie::hat(gravity_) * dt;
  Phi.block<3, 3>(6, 3) = Matrix3::Identity() * dt;
  Phi.block<3, 3>(0, 9) = -R0 * dt;
  Phi.block<3, 3>(3, 9) = -lie::hat(v0) * R0 * dt;
  Phi.block<3, 3>(6, 9) = -lie::hat(p0) * R0 * dt;
  Phi.block<3, 3>(3, 12) = -R0 * dt;

  // Continuous noise of the error: Ad_X diag(Qg, Qa, 0) Ad_X' on the group part, the bias
  // random walks on the biases (diagonal: R Q R' = Q for isotropic noise).
  const double qg = settings_.gyro_noise * settings_.gyro_noise;
  const double qa = settings_.accel_noise * settings_.accel_noise;
  const Matrix3 vx = lie::hat(v0), px = lie::hat(p0);
  Matrix15 Q = Matrix15::Zero();
  Q.block<3, 3>(0, 0) = qg * Matrix3::Identity();
  Q.block<3, 3>(0, 3) = -qg * vx;  // (I)(qg)(v^ R R')' = qg (v^)' = -qg v^
  Q.block<3, 3>(3, 0) = qg * vx;
  Q.block<3, 3>(0, 6) = -qg * px;
  Q.block<3, 3>(6, 0) = qg * px;
  Q.block<3, 3>(3, 3) = -qg * vx * vx + qa * Matrix3::Identity();
  Q.block<3, 3>(3, 6) = -qg * vx * px;
  Q.block<3, 3>(6, 3) = -qg * px * vx;
  Q.block<3, 3>(6, 6) = -qg * px * px;
  Q.block<3, 3>(9, 9) = settings_.gyro_bias_walk * settings_.gyro_bias_walk * Matrix3::Identity();
  Q.block<3, 3>(12, 12) =
      settings_.accel_bias_walk * settings_.accel_bias_walk * Matrix3::Identity();
  P_ = Phi * (P_ + Q * dt) * Phi.transpose();
  P_ = 0.5 * (P_ + P_.transpose()).eval();
}

bool InvariantEkf::encodersValid(const EstimatorInput& in) const noexcept {
  if (in.joint_position.size() != nj_ || in.joint_velocity.size() != nj_) return false;
  const double m = settings_.joint_limit_margin;
  for (int j = 0; j < nj_; ++j) {
    const double q = in.joint_position[j], v = in.joint_velocity[j];
    if (!std::isfinite(q) || !std::isfinite(v)) return false;
    if (q < model_.lowerPositionLimit[j] - m || q > model_.upperPositionLimit[j] + m) return false;
    if (std::abs(v) > settings_.max_joint_velocity) return false;
  }
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    if (contacts_[i].kind != ContactKind::DriveWheel) continue;
    const double s = in.wheel_velocity[i];
    if (!std::isfinite(s) || std::abs(s) > settings_.max_wheel_speed) return false;
  }
  return true;
}

bool InvariantEkf::tick(const EstimatorInput& in) noexcept {
  ++counters_.ticks;
  bool ok = true;
  // IMU sample: a bad one is replaced by the last good one.
  const bool imu_ok = in.gyro.allFinite() && in.accel.allFinite() &&
                      in.gyro.norm() <= settings_.max_angular_rate &&
                      in.accel.norm() <= settings_.max_acceleration;
  if (!imu_ok) {
    ++counters_.imu_rejected;
    record(in.time, EstimatorEvent::ImuRejected, -1);
    ok = false;
  }
  // Time: integrate the held sample over [time_, in.time].
  const double dt = in.time - time_;
  if (!std::isfinite(in.time) || dt < 0.0 || (started_ && dt > settings_.max_dt)) {
    ++counters_.time_rejected;
    record(in.time, EstimatorEvent::TimeRejected, -1);
    if (std::isfinite(in.time) && dt > 0.0) time_ = in.time;  // skip the gap
    if (imu_ok) {
      gyro_last_ = in.gyro;
      accel_last_ = in.accel;
      imu_valid_ = true;
    }
    return false;
  }
  if (started_ && imu_valid_ && dt > 0.0) propagate(dt);
  time_ = in.time;
  started_ = true;
  if (imu_ok) {
    gyro_last_ = in.gyro;
    accel_last_ = in.accel;
    imu_valid_ = true;
  }
  omega_ = gyro_last_ - bg_;
  if (!imu_valid_) return false;

  if (!encodersValid(in)) {
    ++counters_.encoder_rejected;
    record(in.time, EstimatorEvent::EncoderRejected, -1);
    return false;
  }
  qj_ = in.joint_position;
  vj_ = in.joint_velocity;
  update(in);
  omega_ = gyro_last_ - bg_;
  return ok;
}

void InvariantEkf::update(const EstimatorInput& in) noexcept {
  q_.tail(nj_) = in.joint_position;
  model::computeJointJacobians(model_, *data_, q_);
  const Vector3 n = R_.transpose() * Vector3::UnitZ();  // ground normal, base frame
  const Vector3 w = gyro_last_ - bg_;
  const Matrix3 Rt = R_.transpose();
  const Vector3 v_body = Rt * v_;
  const double sq_qd = settings_.joint_velocity_noise * settings_.joint_velocity_noise;
  const double sq_c = settings_.contact_velocity_noise * settings_.contact_velocity_noise;

  RowsMatrix H(kMaxRows, kErrorDim);
  VectorMax r(kMaxRows);
  SquareMax N(kMaxRows, kMaxRows);
  N.setZero();
  // Stance contacts and rejections, all and of the 3-row (horizontal velocity) kinds.
  int rows = 0, stance = 0, rejected = 0, stance3 = 0, rejected3 = 0;
  const bool recovering = all_rejected_ticks_ >= settings_.gate_recovery_ticks;
  if (recovering) {
    // The velocity estimate is what is wrong: give it back its initial uncertainty, so
    // that the measurements move it in one step.
    P_.block<3, 3>(3, 3).diagonal().array() +=
        settings_.initial_velocity * settings_.initial_velocity;
  }

  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    if (!in.contact[i]) continue;
    ++stance;
    const ContactSpec& c = contacts_[i];
    const int f = frames_[i];
    model::updateFramePlacement(model_, *data_, f);
    model::getFrameJacobian(model_, *data_, f, model::ReferenceFrame::LOCAL_WORLD_ALIGNED, J_);
    const Vector3 pc = data_->opf[static_cast<std::size_t>(f)];
    const auto Jl = J_.topRightCorner(3, nj_);
    const auto Ja = J_.bottomRightCorner(3, nj_);
    const Vector3 v_rel = Jl * in.joint_velocity;
    const Vector3 w_rel = Ja * in.joint_velocity;
    const ContactKind kind = settings_.rolling ? c.kind : ContactKind::Point;
    if (kind != ContactKind::OmniWheel) ++stance3;
    Vector3 z = -(w.cross(pc) + v_rel);
    Vector3 lever = pc;  // contact point of the ground, base frame
    Matrix3 Ni = sq_c * Matrix3::Identity() + sq_qd * Jl * Jl.transpose();
    if (kind == ContactKind::DriveWheel) {
      const Vector3 axle = data_->oRf[static_cast<std::size_t>(f)].col(1);
      const Vector3 rn = (c.radius - settings_.rolling_radius_offset) * n;
      z += (w + w_rel + in.wheel_velocity[i] * axle).cross(rn);
      lever = pc - rn;
      const Vector3 g = axle.cross(rn);  // d z / d wheel speed
      Ni += settings_.wheel_velocity_noise * settings_.wheel_velocity_noise * g * g.transpose();
    }
    Eigen::Matrix<double, 3, kErrorDim> Hi = Eigen::Matrix<double, 3, kErrorDim>::Zero();
    Hi.block<3, 3>(0, 3) = Rt;
    Hi.block<3, 3>(0, 9) = lie::hat(lever);
    const Vector3 ri = z - v_body;
    if (kind == ContactKind::OmniWheel) {
      // Only the velocity along the normal: one row.
      const Eigen::Matrix<double, 1, kErrorDim> h = n.transpose() * Hi;
      const double s = (h * P_ * h.transpose())(0, 0) + n.dot(Ni * n);
      const double e = n.dot(ri);
      if (!recovering && settings_.gate_1dof > 0.0 && e * e / s > settings_.gate_1dof) {
        ++rejected;
        ++counters_.contacts_rejected;
        record(in.time, EstimatorEvent::ContactRejected, static_cast<int>(i));
        continue;
      }
      H.row(rows) = h;
      r[rows] = e;
      N(rows, rows) = n.dot(Ni * n);
      rows += 1;
    } else {
      const Matrix3 S = Hi * P_ * Hi.transpose() + Ni;
      const double d2 = ri.dot(S.ldlt().solve(ri));
      if (!recovering && settings_.gate_3dof > 0.0 && !(d2 <= settings_.gate_3dof)) {
        ++rejected;
        ++rejected3;
        ++counters_.contacts_rejected;
        record(in.time, EstimatorEvent::ContactRejected, static_cast<int>(i));
        continue;
      }
      H.middleRows<3>(rows) = Hi;
      r.segment<3>(rows) = ri;
      N.block<3, 3>(rows, rows) = Ni;
      rows += 3;
    }
    ++counters_.contacts_used;
    // Ground point of the contact (world) and, with a map's height, its height row.
    const double radius =
        kind == ContactKind::Point ? 0.0 : c.radius - settings_.rolling_radius_offset;
    const Vector3 w_lin = p_ + R_ * pc;
    contact_point_[i] = w_lin - radius * Vector3::UnitZ();
    const double h = in.ground_height[i];
    if (std::isfinite(h)) {
      Eigen::Matrix<double, 1, kErrorDim> hrow = Eigen::Matrix<double, 1, kErrorDim>::Zero();
      hrow.segment<3>(0) = -(Vector3::UnitZ().transpose() * lie::hat(w_lin));
      hrow(0, 8) = 1.0;
      const double e = h - contact_point_[i].z();
      const double nh = settings_.height_noise * settings_.height_noise;
      const double s = (hrow * P_ * hrow.transpose())(0, 0) + nh;
      if (recovering || settings_.gate_1dof <= 0.0 || e * e / s <= settings_.gate_1dof) {
        H.row(rows) = hrow;
        r[rows] = e;
        N(rows, rows) = nh;
        rows += 1;
      }
    }
  }
  // Every contact that sees the horizontal velocity disagrees with the estimate (or every
  // contact, with omni wheels only): the estimate is what is wrong after a while.
  const bool all_rejected = stance3 > 0 ? rejected3 == stance3 : (stance > 0 && rejected == stance);
  if (all_rejected) {
    ++all_rejected_ticks_;
  } else {
    if (recovering && stance > 0) {
      ++counters_.gate_recoveries;
      record(in.time, EstimatorEvent::GateRecovered, -1);
    }
    all_rejected_ticks_ = 0;
  }
  if (rows == 0) return;

  const auto Hs = H.topRows(rows);
  SquareMax S = Hs * P_ * Hs.transpose() + N.topLeftCorner(rows, rows);
  const Eigen::LDLT<SquareMax> ldlt(S);
  // K = P H' S^-1  (S symmetric): K' = S^-1 H P.
  GainMatrix K = ldlt.solve(Hs * P_).transpose();
  const Eigen::Matrix<double, kErrorDim, 1> dx = K * r.head(rows);
  if (!dx.allFinite()) return;
  leftCompose(dx.head<9>(), R_, v_, p_);
  bg_ += dx.segment<3>(9);
  ba_ += dx.segment<3>(12);
  // Joseph form: stays symmetric positive definite.
  const Matrix15 IKH = Matrix15::Identity() - K * Hs;
  P_ = IKH * P_ * IKH.transpose() + K * N.topLeftCorner(rows, rows) * K.transpose();
  P_ = 0.5 * (P_ + P_.transpose()).eval();
}

}  // namespace rollstep::estimation
