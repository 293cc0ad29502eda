#pragma once
#include "rollstep/model/gravity.hpp"

namespace rollstep::model {

/// dg/dq (nv x nv) in data.dg_dq (and data.g).
const Eigen::MatrixXd& computeGeneralizedGravityDerivatives(
    const Model& model, Data& data, const Eigen::Ref<const Eigen::VectorXd>& q);
/// d(J(q)^T f)/dq at fixed world forces (nv x nv) in data.dtauContact_dq (and data.tauContact).
const Eigen::MatrixXd& computeContactTorqueDerivatives(
    const Model& model, Data& data, const Eigen::Ref<const Eigen::VectorXd>& q,
    const std::vector<FrameIndex>& frames, const Eigen::Ref<const Eigen::VectorXd>& forces);

}  // namespace rollstep::model
