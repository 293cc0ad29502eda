// The CBF-QP baseline's real-time tick (control::BaselinePipeline through
// sim::CbfQpController): no heap allocation over a second of trot ticks in front of the
// step20 block (swings planned at lift-off, collision, support and region rows in the QP);
// a NaN state is refused and the command kept; the command can change mid-run; with
// asynchronous perception the controller's side (rays, the scan's hand-over, the tick)
// allocates nothing either.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "common/alloc_counter.hpp"
#include "sim/cbfqp_run.hpp"
#include "sim/closed_loop_ticks.hpp"

namespace {

using namespace rollstep;
using namespace rollstep::sim;
using sim::test::internalState;
using sim::test::runTicks;

/// The plant on step20, Tachyon 3's OCP description and the baseline's settings.
struct Step20Baseline {
  SceneConfig scene = [] {
    SceneConfig s = loadScene("step20");
    return s;
  }();
  Plant plant{scene};
  centroidal::RobotOcpDescription robot = centroidal::loadRobotOcpDescription(
      std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml");
  control::ControlSettings settings = control::loadControlSettings(sim::test::baselineConfig());
};

TEST(CbfQpController, TickMakesNoAllocationAndRefusesBadStates) {
  Step20Baseline f;
  SceneConfig& scene = f.scene;
  Plant& plant = f.plant;
  const centroidal::RobotOcpDescription& robot = f.robot;
  const control::ControlSettings& settings = f.settings;
  CbfQpController controller(plant, robot, settings,
                             terrainFromScene(scene, settings.baseline.foothold_margin),
                             terrainFromScene(scene, 0.0), planning::GaitKind::Trot,
                             planning::BaseVelocityCommand{0.15, 0, 0});
  runTicks(controller, plant, 30);
  control::BaselinePipeline& pipeline = controller.pipeline();
  control::JointCommand out = pipeline.makeCommand();
  // The internal state moved to 8 cm before the block with the front wheels: collision rows
  // for them; one second spans a lift-off and a touch-down of each trot group.
  control::RobotState s = internalState(pipeline, plant.time());
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

// A new terrain pair (perception's hand-over, BaselinePipeline::setTerrain) mid-trot: the next
// tick swaps it in without allocating and moves the planner's region indices onto it (the
// new terrain numbers its regions differently: the floor in front of the block first, in
// two pieces); every foot then plans in a region of the new terrain that holds its target.
TEST(CbfQpController, TerrainHandOverIsAllocationFreeAndRemapsTheRegions) {
  Step20Baseline f;
  SceneConfig& scene = f.scene;
  Plant& plant = f.plant;
  const centroidal::RobotOcpDescription& robot = f.robot;
  const control::ControlSettings& settings = f.settings;
  const double margin = settings.baseline.foothold_margin;
  CbfQpController controller(plant, robot, settings, terrainFromScene(scene, margin),
                             terrainFromScene(scene, 0.0), planning::GaitKind::Trot,
                             planning::BaseVelocityCommand{0.15, 0, 0}, 0, 8);
  runTicks(controller, plant, 500);  // into the first swings
  control::BaselinePipeline& pipeline = controller.pipeline();
  // The same surfaces, numbered and cut differently: floor before the block in two pieces
  // (y < 0, y > 0), then the block, then the floor beyond.
  const auto box = [](double x0, double x1, double y0, double y1, double h) {
    return planning::ConvexRegion::fromPolygon({{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}, h);
  };
  const planning::TerrainModel solids({box(-5, 1, -1.5, 0, 0), box(-5, 1, 0, 1.5, 0),
                                       box(1, 2.2, -1.5, 1.5, 0.2), box(2.2, 10, -1.5, 1.5, 0)});
  const planning::TerrainModel footholds = planning::shrinkTerrain(solids, margin, 0.04);
  EXPECT_EQ(pipeline.setTerrain(footholds, solids), 1u);
  // Refused: more solids than the capacity (8), or an empty foothold terrain.
  std::vector<planning::ConvexRegion> many;
  for (int k = 0; k < 9; ++k) many.push_back(box(k, k + 1, -1, 1, 0));
  EXPECT_EQ(pipeline.setTerrain(footholds, planning::TerrainModel(many)), 0u);
  EXPECT_EQ(pipeline.setTerrain(planning::TerrainModel(), solids), 0u);

  control::JointCommand out = pipeline.makeCommand();
  std::size_t count = 0;
  runTicks(controller, plant, 20);  // real states, real plans
  control::RobotState s = internalState(pipeline, plant.time());
  EXPECT_EQ(pipeline.terrainVersion(), 1u);
  EXPECT_EQ(pipeline.counters().terrain_updates, 1u);
  // A second hand-over inside the guard: the swap and the remap allocate nothing.
  EXPECT_EQ(pipeline.setTerrain(footholds, solids), 2u);
  {
    s.time += 0.001;
    rollstep::test::AllocationGuard guard;
    pipeline.tick(s, out);
    count += guard.count();
  }
  EXPECT_EQ(count, 0u) << "the tick that took the new terrain allocated";
  EXPECT_EQ(pipeline.terrainVersion(), 2u);
  const control::ReactivePlan& plan = pipeline.plan();
  const int nc = pipeline.robot().nc();
  int stance = 0, swing = 0;
  for (int i = 0; i < nc; ++i) {
    const int region = plan.regions[static_cast<std::size_t>(i)].region;
    ASSERT_GE(region, 0) << "foot " << i;
    ASSERT_LT(region, pipeline.terrain().size()) << "foot " << i;
    if (centroidal::CentroidalRobot::inStance(plan.mode, i)) {
      // A stance target (wheel centre) lies in its region.
      EXPECT_LT(pipeline.terrain().region(region).distance(plan.foot_position.col(i).head<2>()),
                1e-9)
          << "foot " << i;
      ++stance;
    } else {
      ++swing;  // its touch-down region: checked by index above
    }
  }
  EXPECT_GT(stance, 0);
  EXPECT_GT(swing, 0);  // the hand-over happened mid-swing
  EXPECT_EQ(pipeline.collisionTerrain().size(), 4);
}

// Asynchronous perception (OnlinePerceptionOptions::asynchronous): the simulation thread
// casts the LiDAR's rays and posts each scan, the map update, segmentation and terrain run
// on the perception thread, which hands the terrains to the pipeline. Over 1.2 s of ticks
// (12 scans) the simulation thread allocates nothing, every scan is accounted for, and
// the terrains reach the tick.
TEST(CbfQpController, AsynchronousPerceptionLeavesTheTickSideAllocationFree) {
  Step20Baseline f;
  Plant& plant = f.plant;
  OnlinePerceptionOptions options;
  options.asynchronous = true;
  auto perception = std::make_unique<OnlinePerception>(options);
  perception->start(plant, plant.groundTruth().base_position, plant.groundTruth().base_orientation);
  const perception::PerceptionSettings& ps = perception->perception().settings();
  CbfQpController controller(
      plant, f.robot, f.settings, perception->footholdTerrain(f.settings.baseline.foothold_margin),
      perception->terrain(), planning::GaitKind::Trot, planning::BaseVelocityCommand{0.15, 0, 0},
      ps.regions.directions, ps.closed_loop.collision_capacity);
  controller.setPerception(std::move(perception));
  OnlinePerception& p = *controller.perception();
  ASSERT_TRUE(p.asynchronous());
  runTicks(controller, plant, 50);
  PlantCommand command = plant.command();
  std::size_t count = 0;
  for (int k = 0; k < 1200; ++k) {
    {
      rollstep::test::AllocationGuard guard;
      controller.compute(plant.time(), plant.sensors(), command);
      count += guard.count();
    }
    plant.setCommand(command);
    plant.step();
  }
  EXPECT_EQ(count, 0u) << "the simulation thread allocated with asynchronous perception";
  p.stop();  // the scan still waiting is processed: the newest scan always is
  const OnlinePerceptionCounters& c = p.counters();
  EXPECT_EQ(c.scans, 12u);                                     // 0.1, 0.2, ..., 1.2 s
  EXPECT_EQ(c.terrains - 1 + c.kept + c.superseded, c.scans);  // 1: start()'s
  EXPECT_GE(c.handed_over, 1u);
  EXPECT_EQ(c.refused, 0u);
  EXPECT_EQ(c.handed_over, c.terrains - 1);
  runTicks(controller, plant, 2);  // takes the last terrain handed over
  EXPECT_GE(controller.pipeline().counters().terrain_updates, 1u);
  EXPECT_EQ(controller.pipeline().counters().qp_fallbacks, 0u);
  EXPECT_LT(plant.groundTruth().base_orientation.angularDistance(Eigen::Quaterniond::Identity()),
            0.1);
}

// Deterministic perception (the default): the same run twice gives the same robot state and
// the same terrains, bit for bit (the map update, segmentation and hand-over run in the
// simulation thread at each scan's time).
TEST(CbfQpController, DeterministicPerceptionIsBitwiseReproducible) {
  struct Outcome {
    GroundTruth truth;
    std::vector<std::vector<Eigen::Vector2d>> regions;
    std::uint64_t terrain_version = 0;
  };
  const auto run = [] {
    Step20Baseline f;
    Plant& plant = f.plant;
    auto perception = std::make_unique<OnlinePerception>(OnlinePerceptionOptions{});
    perception->start(plant, plant.groundTruth().base_position,
                      plant.groundTruth().base_orientation);
    const perception::PerceptionSettings& ps = perception->perception().settings();
    CbfQpController controller(plant, f.robot, f.settings,
                               perception->footholdTerrain(f.settings.baseline.foothold_margin),
                               perception->terrain(), planning::GaitKind::Trot,
                               planning::BaseVelocityCommand{0.15, 0, 0}, ps.regions.directions,
                               ps.closed_loop.collision_capacity);
    controller.setPerception(std::move(perception));
    runTicks(controller, plant, 800);
    Outcome o;
    o.truth = plant.groundTruth();
    for (int r = 0; r < controller.pipeline().terrain().size(); ++r) {
      o.regions.push_back(controller.pipeline().terrain().region(r).vertices);
    }
    o.terrain_version = controller.pipeline().terrainVersion();
    return o;
  };
  const Outcome a = run(), b = run();
  EXPECT_GE(a.terrain_version, 7u);  // one per scan (0.1 ... 0.8 s)
  EXPECT_EQ(a.terrain_version, b.terrain_version);
  EXPECT_EQ(a.regions, b.regions);
  EXPECT_EQ(a.truth.base_position, b.truth.base_position);
  EXPECT_EQ(a.truth.base_orientation.coeffs(), b.truth.base_orientation.coeffs());
  EXPECT_EQ(a.truth.joint_position, b.truth.joint_position);
}

}  // namespace
