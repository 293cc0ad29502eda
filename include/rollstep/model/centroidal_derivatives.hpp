#pragma once
#include "rollstep/model/centroidal.hpp"

namespace rollstep::model {

/// d(A(q) v)/dq at fixed v (6 x nv) in data.dhg_dq; d(A(q) v)/dv = data.Ag.
/// Also fills everything computeCentroidalMomentum fills (data.hg, data.Ag, ...).
const Matrix6Xd& computeCentroidalMomentumDerivatives(const Model& model, Data& data,
                                                      const Eigen::Ref<const Eigen::VectorXd>& q,
                                                      const Eigen::Ref<const Eigen::VectorXd>& v);

}  // namespace rollstep::model
