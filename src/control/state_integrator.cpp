#include "rollstep/control/state_integrator.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rollstep::control {

StateIntegrator::StateIntegrator(std::shared_ptr<const model::Model> model,
                                 const IntegratorSettings& settings, double dt)
    : model_(std::move(model)), settings_(settings), dt_(dt) {
  if (!model_) throw std::invalid_argument("StateIntegrator: null model");
  if (!(dt > 0.0) || !std::isfinite(dt)) {
    throw std::invalid_argument("StateIntegrator: dt must be finite and > 0");
  }
  if (!(settings.position_time_constant >= 0.0) || !(settings.velocity_time_constant >= 0.0) ||
      !std::isfinite(settings.position_time_constant) ||
      !std::isfinite(settings.velocity_time_constant)) {
    throw std::invalid_argument("StateIntegrator: time constants must be finite and >= 0");
  }
  q_ = Eigen::VectorXd::Zero(model_->nq);
  if (model_->root == model::RootJoint::FreeFlyer) q_[6] = 1.0;
  v_ = Eigen::VectorXd::Zero(model_->nv);
  dq_ = Eigen::VectorXd::Zero(model_->nv);
  q_tmp_ = q_;
}

void StateIntegrator::reset(const Eigen::Ref<const Eigen::VectorXd>& q,
                            const Eigen::Ref<const Eigen::VectorXd>& v) {
  q_ = q;
  v_ = v;
}

void StateIntegrator::step(const Eigen::Ref<const Eigen::VectorXd>& a,
                           const Eigen::Ref<const Eigen::VectorXd>& q_measured,
                           const Eigen::Ref<const Eigen::VectorXd>& v_measured) noexcept {
  if (settings_.mode == IntegratorMode::Internal) {
    // Share of the difference to the measurement taken this tick (1: take the measurement).
    const auto share = [&](double tau) { return tau <= dt_ ? 1.0 : dt_ / tau; };
    if (q_measured.allFinite()) {
      model::difference(*model_, q_, q_measured, dq_);
      dq_ *= share(settings_.position_time_constant);
      model::integrate(*model_, q_, dq_, q_tmp_);
      q_ = q_tmp_;
    }
    if (v_measured.allFinite()) v_ += share(settings_.velocity_time_constant) * (v_measured - v_);
  }
  if (a.allFinite()) v_ += dt_ * a;
  dq_ = dt_ * v_;
  model::integrate(*model_, q_, dq_, q_tmp_);
  q_ = q_tmp_;
}

}  // namespace rollstep::control
