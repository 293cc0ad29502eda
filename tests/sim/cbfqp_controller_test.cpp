// The CBF-QP baseline's real-time tick (control::BaselinePipeline through
// sim::CbfQpController): no heap allocation over a second of trot ticks in front of the
// step20 block (swings planned at lift-off, collision, support and region rows in the QP);
// a NaN state is refused and the command kept; the command can change mid-run.
#include <gtest/gtest.h>

#include <cmath>

#include "common/alloc_counter.hpp"
#include "sim/cbfqp_run.hpp"

namespace {

using namespace rollstep;
using namespace rollstep::sim;

TEST(CbfQpController, TickMakesNoAllocationAndRefusesBadStates) {
  SceneConfig scene;
  scene.kind = SceneKind::kStep20;
  Plant plant(scene);
  const centroidal::RobotOcpDescription robot = centroidal::loadRobotOcpDescription(
      std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml");
  const control::ControlSettings settings =
      control::loadControlSettings(sim::test::baselineConfig());
  CbfQpController controller(plant, robot, settings,
                             terrainFromScene(scene, settings.baseline.foothold_margin),
                             terrainFromScene(scene, 0.0), planning::GaitKind::Trot,
                             planning::BaseVelocityCommand{0.15, 0, 0});
  PlantCommand command = plant.command();
  for (int k = 0; k < 30; ++k) {
    controller.compute(plant.time(), plant.sensors(), command);
    plant.setCommand(command);
    plant.step();
  }
  control::BaselinePipeline& pipeline = controller.pipeline();
  control::JointCommand out = pipeline.makeCommand();
  // The internal state moved to 8 cm before the block with the front wheels: collision rows
  // for them; one second spans a lift-off and a touch-down of each trot group.
  control::RobotState s = pipeline.makeState();
  control::fromModelState(plant.time(), pipeline.integrator().q(), pipeline.integrator().v(), s);
  s.base_position.x() = 1.0 - 0.33 - 0.08;
  std::size_t count = 0;
  int max_rows = 0;
  for (int k = 0; k < 1000; ++k) {
    s.time += 0.001;
    rollstep::test::AllocationGuard guard;
    pipeline.tick(s, out);
    count += guard.count();
    max_rows = std::max(max_rows, pipeline.filter().lastProblem().nIneq());
  }
  EXPECT_EQ(count, 0u) << "the real-time tick allocated";
  EXPECT_GE(max_rows, 6);  // support (3) and collision rows at least
  EXPECT_TRUE(out.joint_position.allFinite());

  // A NaN in the state: refused, the command kept.
  const control::JointCommand before = out;
  const std::uint64_t invalid = pipeline.counters().invalid_states;
  s.time += 0.001;
  s.joint_velocity[3] = std::nan("");
  pipeline.tick(s, out);
  EXPECT_FALSE(pipeline.lastTick().state_valid);
  EXPECT_EQ(pipeline.counters().invalid_states, invalid + 1);
  EXPECT_EQ(out.joint_position, before.joint_position);
  EXPECT_EQ(out.wheel_velocity, before.wheel_velocity);
}

}  // namespace
