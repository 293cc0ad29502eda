#pragma once
// Helpers shared by the model-layer tests: robots under test, random states, central
// finite differences on the configuration manifold.
#include <gtest/gtest.h>

#include <cmath>
#include <ostream>
#include <random>
#include <string>
#include <vector>

#include "rollstep/model/all.hpp"

namespace rollstep::model::test {

struct RobotCase {
  std::string name;
  std::string path;
  RootJoint root;
  std::vector<std::string> contacts;  // frames used as contact points
};

inline std::vector<RobotCase> robotCases() {
  const std::string robots = ROLLSTEP_ROBOTS_DIR;
  const std::string data = ROLLSTEP_TEST_DATA_DIR;
  return {
      {"tachyon3",
       robots + "/tachyon3/tachyon3.urdf",
       RootJoint::FreeFlyer,
       {"LF_contact", "MF_contact", "RF_contact", "LR_contact", "MR_contact", "RR_contact"}},
      {"arm7_fixed", data + "/arm7.urdf", RootJoint::Fixed, {"tool", "arm_link4"}},
      {"arm7_floating", data + "/arm7.urdf", RootJoint::FreeFlyer, {"tool", "flange"}},
      {"quadruped",
       data + "/quadruped.urdf",
       RootJoint::FreeFlyer,
       {"FL_foot", "FR_foot", "HL_foot", "HR_foot"}},
  };
}

inline void PrintTo(const RobotCase& c, std::ostream* os) { *os << c.name; }

inline std::string robotCaseName(const ::testing::TestParamInfo<RobotCase>& p) {
  return p.param.name;
}

inline std::vector<FrameIndex> frameIds(const Model& m, const std::vector<std::string>& names) {
  std::vector<FrameIndex> ids;
  for (const auto& n : names) ids.push_back(m.getFrameId(n));
  return ids;
}

inline Eigen::VectorXd randomConfiguration(const Model& m, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::VectorXd q(m.nq);
  if (m.hasFreeFlyer()) {
    q.head<3>() = Eigen::Vector3d(n(rng), n(rng), n(rng));
    q.segment<4>(3) = Eigen::Vector4d(n(rng), n(rng), n(rng), n(rng)).normalized();
  }
  for (int j = 0; j < m.nj; ++j) {
    double lo = m.lowerPositionLimit[j];
    double hi = m.upperPositionLimit[j];
    if (!std::isfinite(lo) || !std::isfinite(hi)) {
      lo = -3.0;
      hi = 3.0;
    }
    q[m.nqBase + j] = lo + (hi - lo) * u(rng);
  }
  return q;
}

inline Eigen::VectorXd randomVector(int n, std::mt19937& rng, double scale = 1.0) {
  std::normal_distribution<double> d(0.0, scale);
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = d(rng);
  return v;
}

/// Central finite difference of f(q (+) dq) w.r.t. the tangent dq.
template <class F>
Eigen::MatrixXd fdConfiguration(const Model& m, const Eigen::VectorXd& q, const F& f,
                                double h = 1e-6) {
  const Eigen::VectorXd f0 = f(q);
  Eigen::MatrixXd out(f0.size(), m.nv);
  Eigen::VectorXd qp(m.nq);
  Eigen::VectorXd qm(m.nq);
  for (int i = 0; i < m.nv; ++i) {
    const Eigen::VectorXd e = Eigen::VectorXd::Unit(m.nv, i) * h;
    integrate(m, q, e, qp);
    integrate(m, q, -e, qm);
    out.col(i) = (f(qp) - f(qm)) / (2 * h);
  }
  return out;
}

/// |a - b|_max <= tol * max(1, |a|_max).
inline ::testing::AssertionResult closeRelative(const Eigen::MatrixXd& analytic,
                                                const Eigen::MatrixXd& reference, double tol) {
  if (analytic.rows() != reference.rows() || analytic.cols() != reference.cols()) {
    return ::testing::AssertionFailure() << "size mismatch";
  }
  const double err = (analytic - reference).cwiseAbs().maxCoeff();
  const double scale = std::max(1.0, analytic.cwiseAbs().maxCoeff());
  if (err <= tol * scale) return ::testing::AssertionSuccess();
  Eigen::Index r = 0;
  Eigen::Index c = 0;
  (analytic - reference).cwiseAbs().maxCoeff(&r, &c);
  return ::testing::AssertionFailure()
         << "max error " << err << " > " << tol << " * " << scale << " at (" << r << ", " << c
         << "): analytic " << analytic(r, c) << " reference " << reference(r, c);
}

}  // namespace rollstep::model::test
