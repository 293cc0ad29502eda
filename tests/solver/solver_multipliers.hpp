#pragma once
// The solver's multipliers in the layout nltest::kktResidual expects, for the tests that
// check a Solver's solution independently (documented in solver.hpp: L = cost + nu^T e +
// lambda^T defects - z^T g; duals [general | input lo, hi | state lo, hi]).
#include <vector>

#include "nonlinear_problems.hpp"
#include "rollstep/solver/solver.hpp"

namespace rollstep::nltest {

inline KktInputs solverMultipliers(const solver::Solver& s, const ocp::OptimalControlProblem& pb) {
  auto d = pb.createNodeData();
  std::vector<int> ne, ni;
  const VectorXd u0 = VectorXd::Zero(pb.nu());
  for (int k = 0; k <= pb.horizon(); ++k) {
    const auto kk = static_cast<size_t>(k);
    pb.evaluate(k, s.states()[kk], k < pb.horizon() ? s.inputs()[kk] : u0, *d);
    ne.push_back(k < pb.horizon() ? d->ne : 0);
    ni.push_back(d->ni);
  }
  const int mi = pb.maxInequalities(), nbu = pb.inputBounds().size(), nbx = pb.stateBounds().size();
  KktInputs in;
  in.equality_sign = 1.0;
  in.equality_multipliers = [&s, ne](int k) {
    return VectorXd(s.equalityMultipliers(k).head(ne[static_cast<size_t>(k)]));
  };
  in.inequality_duals = [&s, ni](int k) {
    return VectorXd(s.inequalityDuals(k).head(ni[static_cast<size_t>(k)]));
  };
  in.input_bound_duals = [&s, mi, nbu](int k) {
    return VectorXd(s.inequalityDuals(k).segment(mi, 2 * nbu));
  };
  in.state_bound_duals = [&s, mi, nbu, nbx](int k) {
    return VectorXd(s.inequalityDuals(k).segment(mi + 2 * nbu, 2 * nbx));
  };
  return in;
}

}  // namespace rollstep::nltest
