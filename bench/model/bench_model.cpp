// Rigid-body model benchmarks on the Tachyon 3 URDF at a random state.
//   build-*/bench/model/bench_model [--robot path.urdf]
#include <benchmark/benchmark.h>

#include <random>
#include <string>
#include <vector>

#include "rollstep/model/all.hpp"

namespace {

using namespace rollstep::model;

struct Fixture {
  Model model;
  Data data;
  std::vector<FrameIndex> contacts;
  NodeQuantities node;
  Eigen::VectorXd q;
  Eigen::VectorXd v;
  Eigen::VectorXd f;

  static Model load() {
    return buildModelFromUrdfFile(std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/tachyon3.urdf");
  }
  static std::vector<FrameIndex> contactFrames(const Model& m) {
    std::vector<FrameIndex> ids;
    for (const char* n :
         {"LF_contact", "MF_contact", "RF_contact", "LR_contact", "MR_contact", "RR_contact"}) {
      ids.push_back(m.getFrameId(n));
    }
    return ids;
  }
  Fixture() : model(load()), data(model), contacts(contactFrames(model)), node(model, contacts) {
    std::mt19937 rng(12345);
    std::normal_distribution<double> n(0.0, 1.0);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    q = neutralConfiguration(model);
    q.head<3>() << n(rng), n(rng), 0.4 + 0.1 * n(rng);
    q.segment<4>(3) = Eigen::Vector4d(0.1 * n(rng), 0.1 * n(rng), 0.3 * n(rng), 1.0).normalized();
    for (int j = 0; j < model.nj; ++j) {
      q[7 + j] = model.lowerPositionLimit[j] +
                 (model.upperPositionLimit[j] - model.lowerPositionLimit[j]) * u(rng);
    }
    v.resize(model.nv);
    for (int i = 0; i < model.nv; ++i) v[i] = n(rng);
    f.resize(3 * static_cast<int>(contacts.size()));
    for (int i = 0; i < f.size(); ++i) f[i] = 10.0 * n(rng) + (i % 3 == 2 ? 90.0 : 0.0);
  }
};

Fixture& fixture() {
  static Fixture fx;
  return fx;
}

// Everything one MPC node needs: 6 contact positions and world linear velocities, COM,
// A(q), h = A v, g(q), J^T f, and all their derivatives (w.r.t. q and v).
void BM_AllNodeQuantitiesWithDerivatives(benchmark::State& state) {
  Fixture& fx = fixture();
  for (auto _ : state) {
    computeNodeQuantities(fx.model, fx.data, fx.q, fx.v, fx.f, fx.node);
    benchmark::DoNotOptimize(fx.node.dh_dq.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_AllNodeQuantitiesWithDerivatives);

// The full-centroidal variant: v_b = A_b^-1 (h - A_J v_J) solved inside, plus d v_b/dq and
// d v_b/dv_J on top of everything above.
void BM_AllNodeQuantitiesFromMomentum(benchmark::State& state) {
  Fixture& fx = fixture();
  computeNodeQuantities(fx.model, fx.data, fx.q, fx.v, fx.f, fx.node);
  const Vector6d h = fx.node.h;
  const Eigen::VectorXd vJ = fx.v.tail(fx.model.nj);
  for (auto _ : state) {
    computeNodeQuantitiesFromMomentum(fx.model, fx.data, fx.q, h, vJ, fx.f, fx.node);
    benchmark::DoNotOptimize(fx.node.dvb_dq.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_AllNodeQuantitiesFromMomentum);

void BM_ForwardKinematics(benchmark::State& state) {
  Fixture& fx = fixture();
  for (auto _ : state) {
    forwardKinematics(fx.model, fx.data, fx.q);
    benchmark::DoNotOptimize(fx.data.opb.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_ForwardKinematics);

void BM_ForwardKinematicsVelocity(benchmark::State& state) {
  Fixture& fx = fixture();
  for (auto _ : state) {
    forwardKinematics(fx.model, fx.data, fx.q, fx.v);
    benchmark::DoNotOptimize(fx.data.ov.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_ForwardKinematicsVelocity);

void BM_CentroidalMap(benchmark::State& state) {
  Fixture& fx = fixture();
  for (auto _ : state) {
    computeCentroidalMap(fx.model, fx.data, fx.q);
    benchmark::DoNotOptimize(fx.data.Ag.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_CentroidalMap);

void BM_CentroidalMomentumDerivatives(benchmark::State& state) {
  Fixture& fx = fixture();
  for (auto _ : state) {
    computeCentroidalMomentumDerivatives(fx.model, fx.data, fx.q, fx.v);
    benchmark::DoNotOptimize(fx.data.dhg_dq.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_CentroidalMomentumDerivatives);

void BM_GeneralizedGravityDerivatives(benchmark::State& state) {
  Fixture& fx = fixture();
  for (auto _ : state) {
    computeGeneralizedGravityDerivatives(fx.model, fx.data, fx.q);
    benchmark::DoNotOptimize(fx.data.dg_dq.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_GeneralizedGravityDerivatives);

void BM_ContactTorqueDerivatives(benchmark::State& state) {
  Fixture& fx = fixture();
  for (auto _ : state) {
    computeContactTorqueDerivatives(fx.model, fx.data, fx.q, fx.contacts, fx.f);
    benchmark::DoNotOptimize(fx.data.dtauContact_dq.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_ContactTorqueDerivatives);

}  // namespace

// main: bench/common/bench_main.cpp
