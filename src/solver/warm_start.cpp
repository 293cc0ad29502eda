// How does a solve start from the last one? The real-time warm start: the stored solution
// moves along its node grid by the whole nodes the problem's initial time moved
// (shiftNodes), and the backup of the iterate before a step (backup/restore), which every
// failure that keeps the last good iterate falls back on.
#include "solver_impl.hpp"

namespace rollstep::solver {

/// Moves the problem to start at t0 and the stored solution with it (see Solver::update).
void Solver::Impl::shiftToTime(double t0) {
  // The stored solution lives on the node grid that starts at solution_t0; it moves by
  // whole nodes only, so that updates faster than dt add up to a shift when they cover
  // one (the problem itself starts at t0, less than one node later).
  const double dt = prob->dt();
  last_shift = 0;
  const double nodes_moved = (t0 - solution_t0) / dt;
  if (!has_solution || !(nodes_moved > -1e-6) || nodes_moved >= 1e9) {
    solution_t0 = t0;  // nothing to shift, time went backwards, or a jump of ages
  } else {
    const int shift = static_cast<int>(std::floor(nodes_moved + 1e-6));
    if (shift > 0) {
      shiftNodes(std::min(shift, N));
      last_shift = shift;
      solution_t0 += shift * dt;
    }
  }
  prob->setInitialTime(t0);
  // Appended inputs repeat the old last one, and a node whose time crossed a mode switch
  // keeps the input of its old mode: the problem may fit those to their nodes.
  if (has_solution && prob->inputGuess()) {
    for (int k = 0; k < N; ++k) {
      const bool appended = k >= N - last_shift;
      const ocp::NodeContext ctx = prob->context(k);
      if (appended || ctx.mode != node(k).mode_prev) {
        prob->inputGuess()(ctx, xs[static_cast<std::size_t>(k)], us[static_cast<std::size_t>(k)]);
      }
    }
  }
}

/// Moves the solution n whole nodes earlier (warm start of a real-time update): node k
/// takes node k + n; the tail repeats the old last state and input, its slacks and duals
/// are reinitialised. The backup iterate is shifted the same way.
void Solver::Impl::shiftNodes(int n) {
  auto shiftStates = [&](std::vector<VectorXd>& v) {
    for (int k = 0; k + n <= N; ++k)
      v[static_cast<std::size_t>(k)].swap(v[static_cast<std::size_t>(k + n)]);
    const auto last = static_cast<std::size_t>(N - n);
    for (int k = N - n + 1; k <= N; ++k) v[static_cast<std::size_t>(k)] = v[last];
  };
  auto shiftInputs = [&](std::vector<VectorXd>& v) {
    for (int k = 0; k + n < N; ++k)
      v[static_cast<std::size_t>(k)].swap(v[static_cast<std::size_t>(k + n)]);
    const auto last = static_cast<std::size_t>(N - 1 - n >= 0 ? N - 1 - n : N - 1);
    for (int k = std::max(N - n, 0); k < N; ++k) v[static_cast<std::size_t>(k)] = v[last];
  };
  shiftStates(xs);
  shiftStates(xs_bak);
  shiftInputs(us);
  shiftInputs(us_bak);
  for (int k = 0; k + n <= N; ++k) {
    Node& a = node(k);
    Node& b = node(k + n);
    a.s.swap(b.s);
    a.z.swap(b.z);
    a.lam.swap(b.lam);
    a.mult.swap(b.mult);
    a.s_bak.swap(b.s_bak);
    a.z_bak.swap(b.z_bak);
    a.lam_bak.swap(b.lam_bak);
    a.mult_bak.swap(b.mult_bak);
    std::swap(a.ni_prev, b.ni_prev);
    std::swap(a.mode_prev, b.mode_prev);
  }
  // The new tail repeats the old last running node (now at N - 1 - n) and the old terminal
  // node (now at N - n, moved to N); it takes their slacks and duals too, as it takes their
  // states and inputs. Reinitialised ones (z = mu / s, a weak barrier) let the next step
  // run a tail input through its bounds, and the fraction to the boundary then cut the
  // whole horizon's step, one shift after another. A node whose rows change with its mode
  // is still reinitialised at its linearisation (ni != ni_prev).
  const int last_running = N - 1 - n;
  if (n >= 1 && last_running >= 0) {
    Node& terminal = node(N);
    const Node& old_terminal = node(N - n);
    terminal.s = old_terminal.s;
    terminal.z = old_terminal.z;
    terminal.ni_prev = old_terminal.ni_prev;
    terminal.fresh = old_terminal.fresh;
    const Node& src = node(last_running);
    for (int k = N - n; k < N; ++k) {
      Node& t = node(k);
      t.s = src.s;
      t.z = src.z;
      t.mult = src.mult;
      t.ni_prev = src.ni_prev;
      t.fresh = src.fresh;
    }
    for (int k = N - n; k <= N; ++k) {
      Node& t = node(k);
      t.lam.setZero();
      t.lam_bak.setZero();
      t.s_bak = t.s;
      t.z_bak = t.z;
      t.mult_bak = t.mult;
    }
  } else {
    for (int k = std::max(N - n, 0); k <= N; ++k) {
      Node& t = node(k);
      t.fresh = true;
      t.lam.setZero();
      t.lam_bak.setZero();
      t.s_bak = t.s;
      t.z_bak = t.z;
    }
  }
}

void Solver::Impl::backup() {
  for (int k = 0; k <= N; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    Node& n = node(k);
    xs_bak[kk] = xs[kk];
    if (k < N) us_bak[kk] = us[kk];
    n.s_bak = n.s;
    n.z_bak = n.z;
    n.lam_bak = n.lam;
    n.mult_bak = n.mult;
  }
}

void Solver::Impl::restore() {
  for (int k = 0; k <= N; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    Node& n = node(k);
    xs[kk] = xs_bak[kk];
    if (k < N) us[kk] = us_bak[kk];
    n.s = n.s_bak;
    n.z = n.z_bak;
    n.lam = n.lam_bak;
    n.mult = n.mult_bak;
  }
}

}  // namespace rollstep::solver
