#pragma once
// The internal state integrator (paper Sec. 3.3, Fig. 8; Kuindersma et al. 2016): the
// commanded state (q, v) of the robot, advanced every tick by the CBF-QP's filtered
// acceleration and pulled towards the measured state:
//
//   q <- q (+) (dt / tau_q) (q_meas (-) q)        v <- v + (dt / tau_v) (v_meas - v)
//   v <- v + dt a                                 q <- q (+) dt v
//
// (blend first, then integrate: semi-implicit Euler on the model's configuration space).
// The joint part of q is what the position-controlled joints are commanded to. Because
// the commands come from this smooth internal state rather than from the measurement,
// the prediction errors of the MPC do not make the joint commands oscillate, while the
// blend keeps feeding the actual state back. IntegratorMode::Naive is naive state
// feedback: no blend; the owner restarts the state from the measurement (reset()) whenever
// a new MPC solution is taken, so every update moves the commands by the servos' tracking
// error and the MPC's prediction error.
//
// Memory: sized at construction; step() and reset() never allocate, lock or throw.
#include <Eigen/Core>
#include <memory>

#include "rollstep/control/control_settings.hpp"
#include "rollstep/model/model.hpp"

namespace rollstep::control {

class StateIntegrator {
 public:
  /// Throws std::invalid_argument for a null model, dt <= 0 or negative time constants.
  StateIntegrator(std::shared_ptr<const model::Model> model, const IntegratorSettings& settings,
                  double dt);

  /// Starts from (q, v). Sizes nq, nv. Never allocates (real-time: Naive restarts here).
  void reset(const Eigen::Ref<const Eigen::VectorXd>& q,
             const Eigen::Ref<const Eigen::VectorXd>& v);
  /// One tick: blends the measurement in (IntegratorMode::Internal only), then integrates
  /// the acceleration a (nv). A non-finite a is treated as zero; a non-finite measurement is
  /// not blended in.
  void step(const Eigen::Ref<const Eigen::VectorXd>& a,
            const Eigen::Ref<const Eigen::VectorXd>& q_measured,
            const Eigen::Ref<const Eigen::VectorXd>& v_measured) noexcept;

  const Eigen::VectorXd& q() const { return q_; }
  const Eigen::VectorXd& v() const { return v_; }
  const IntegratorSettings& settings() const { return settings_; }
  double dt() const { return dt_; }

 private:
  std::shared_ptr<const model::Model> model_;
  IntegratorSettings settings_;
  double dt_;
  Eigen::VectorXd q_, v_, dq_, q_tmp_;
};

}  // namespace rollstep::control
