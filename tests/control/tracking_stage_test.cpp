// The tracking stage of both pipelines (tracking_stage.hpp): the feet and the configuration
// error of the internal state, the filter's outcome recorded and counted (a fallback
// included), one integrator step commanding the joints; nothing allocates after
// construction.
#include "rollstep/control/tracking_stage.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "centroidal/fd_check.hpp"
#include "common/alloc_counter.hpp"
#include "rollstep/model/kinematics.hpp"

namespace {

using namespace rollstep;
using control::TrackingStage;
using Eigen::Vector3d;
using Eigen::VectorXd;
namespace ct = centroidal::test;

planning::TerrainModel farFloor() {
  return planning::terrainFromBoxes({-50.0, 50.0, -50.0, 50.0, 0.0}, -10.0, {});
}

TEST(TrackingStage, FeetAndConfigurationErrorAreThoseOfTheInternalState) {
  const auto robot = ct::tachyon3Robot();
  const model::Model& m = robot->model();
  const planning::TerrainModel terrain = farFloor();
  TrackingStage stage(robot, terrain, control::ControlSettings{}, 0.0);
  std::mt19937 rng(21);
  const VectorXd q = ct::randomState(*robot, rng, 0.3).head(robot->nq());
  VectorXd v(robot->nv());
  for (int k = 0; k < v.size(); ++k) v[k] = 0.1 * k - 0.4;
  stage.reset(q, v);
  stage.updateFeet();
  model::Data d(m);
  model::forwardKinematics(m, d, q, v);
  for (int i = 0; i < robot->nc(); ++i) {
    const model::FrameIndex f = robot->frameIds()[static_cast<size_t>(i)];
    model::updateFramePlacement(m, d, f);
    EXPECT_LE((stage.footPositions().col(i) - d.opf[static_cast<size_t>(f)]).norm(), 1e-12);
    const Vector3d vf =
        model::getFrameVelocity(m, d, f, model::ReferenceFrame::LOCAL_WORLD_ALIGNED).head<3>();
    EXPECT_LE((stage.footVelocities().col(i) - vf).norm(), 1e-12);
  }
  // q (+) error = the reference.
  const VectorXd q_ref = ct::randomState(*robot, rng, 0.3).head(robot->nq());
  const VectorXd& dq = stage.configurationError(q_ref);
  VectorXd back(robot->nq());
  model::integrate(m, q, dq, back);
  EXPECT_LE((back.head<3>() - q_ref.head<3>()).norm(), 1e-9);
  EXPECT_LE((back.tail(robot->nj()) - q_ref.tail(robot->nj())).norm(), 1e-9);
  EXPECT_NEAR(std::abs(back.segment<4>(3).dot(q_ref.segment<4>(3))), 1.0, 1e-9);
}

TEST(TrackingStage, FiltersRecordsAndStepsWithoutAllocating) {
  const auto robot = ct::tachyon3Robot();
  const planning::TerrainModel terrain = farFloor();
  const control::ControlSettings settings;
  TrackingStage stage(robot, terrain, settings, 0.0);
  const VectorXd q0 = ct::nominalState(*robot).head(robot->nq());
  const VectorXd v0 = VectorXd::Zero(robot->nv());
  stage.reset(q0, v0);
  control::JointCommand command;
  command.joint_position = VectorXd::Zero(robot->nj());
  command.joint_velocity = VectorXd::Zero(robot->nj());
  control::TickRecord record;
  control::PipelineCounters counters;
  const int nj = robot->nj();
  {
    test::AllocationGuard guard;
    // All feet in swing, a joint acceleration asked for: no barrier near, granted.
    stage.updateFeet();
    stage.targets().joints.setConstant(0.5);
    EXPECT_FALSE(stage.filter(0, nullptr, record, counters));
    EXPECT_EQ(record.cbf_status, control::CbfQpStatus::Optimal);
    EXPECT_EQ(record.qp_iterations, stage.safetyFilter().qpIterations());
    EXPECT_EQ(counters.qp_fallbacks, 0u);
    const VectorXd& a = stage.acceleration();
    stage.step(q0, v0, command);
    // The command is the new internal state's joints, moved by the filtered acceleration.
    EXPECT_TRUE(command.joint_position == stage.q().tail(nj));
    EXPECT_TRUE(command.joint_velocity == stage.v().tail(nj));
    EXPECT_GT(a.tail(nj).norm(), 0.1);
    EXPECT_LE((stage.v() - settings.control_period * a).norm(), 1e-12);
    // Non-finite targets: the fallback, recorded and counted.
    stage.targets().joints[0] = std::nan("");
    EXPECT_TRUE(stage.filter(0, nullptr, record, counters));
    EXPECT_EQ(record.cbf_status, control::CbfQpStatus::InvalidInput);
    EXPECT_EQ(counters.qp_fallbacks, 1u);
    EXPECT_EQ(guard.count(), 0u);
  }
}

}  // namespace
