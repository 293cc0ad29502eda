#pragma once
// An affine residual whose first 2 m rows are declared two-sided limits (row j + m has the
// negated Jacobian of row j: Residual::mirroredRows), for the ocp and solver tests of the
// pairwise condensing.
#include <memory>
#include <utility>

#include "rollstep/ocp/residuals.hpp"

namespace rollstep::test {

class MirroredAffine final : public ocp::AffineResidual {
 public:
  MirroredAffine(std::shared_ptr<const ocp::StateSpace> s, const ocp::MatrixXd& C,
                 const ocp::MatrixXd& D, const ocp::VectorXd& c, int m)
      : AffineResidual(std::move(s), ocp::VectorXd::Zero(C.cols()), C, D, c), m_(m) {}
  int mirroredRows(const ocp::NodeContext&) const override { return m_; }

 private:
  int m_;
};

}  // namespace rollstep::test
