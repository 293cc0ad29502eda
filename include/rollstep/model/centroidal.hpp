#pragma once
// Centroidal momentum matrix A(q) = [A_b A_J] (6 x nv): h = A(q) v is the total momentum,
// [linear (3); angular about the centre of mass (3)], in world axes.
#include "rollstep/model/data.hpp"

namespace rollstep::model {

/// Fills data.Ag (and data.com, data.Jcom, data.J, placements).
const Matrix6Xd& computeCentroidalMap(const Model& model, Data& data,
                                      const Eigen::Ref<const Eigen::VectorXd>& q);
/// Fills data.hg = data.Ag v (and everything computeCentroidalMap fills, data.ov).
const Vector6d& computeCentroidalMomentum(const Model& model, Data& data,
                                          const Eigen::Ref<const Eigen::VectorXd>& q,
                                          const Eigen::Ref<const Eigen::VectorXd>& v);

}  // namespace rollstep::model
