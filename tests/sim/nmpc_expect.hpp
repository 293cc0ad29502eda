#pragma once
// The closed-loop NMPC tests' common pass criteria.
#include <gtest/gtest.h>

#include "sim/nmpc_run.hpp"

namespace rollstep::sim::test {

/// The first solve converged; roll and pitch below max_tilt_deg, the body above 0.25 m,
/// every joint inside its range, no invalid state, no simulator warning.
inline void expectUpright(const NmpcOutcome& o, double max_tilt_deg = 5.0) {
  EXPECT_TRUE(o.initial_status == solver::SolverStatus::Converged ||
              o.initial_status == solver::SolverStatus::Acceptable)
      << describe(o);
  EXPECT_LT(o.max_roll_deg, max_tilt_deg) << describe(o);
  EXPECT_LT(o.max_pitch_deg, max_tilt_deg) << describe(o);
  EXPECT_GT(o.min_base_height, 0.25) << describe(o);
  EXPECT_LT(o.max_joint_limit_violation, 1e-3) << describe(o);
  EXPECT_EQ(o.counters.invalid_states, 0u);
  EXPECT_EQ(o.warnings, 0) << describe(o);
}

}  // namespace rollstep::sim::test
