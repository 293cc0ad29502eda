// Perception in closed loop (issue 15, label closedloop, Release): the simulated LiDAR scans
// at 10 Hz, each scan is fused at the base pose the controller runs on and hands a new
// terrain to the pipeline while it runs.
// - The NMPC (deterministic, on the state estimator) trots on flat ground on the perceived
//   terrain alone as far as on the scene's ground truth, and a blinded LiDAR (every ray a
//   NaN for a second) keeps the last terrain: no new terrain reaches the pipeline, the robot
//   trots on.
// - The CBF-QP baseline climbs over step20 on the perceived terrain (its planner's region
//   indices are moved onto every new terrain; the shadow behind the block's far edge is
//   filled with the floor's height).
// - The baseline climbs stairs2 up and down on the perceived terrain, and the regions built
//   from the LiDAR while it drives up (fused at its base pose, the robot pitching over the
//   first rise) match the scene: area IoU >= 0.9, rising edges within 2 cm, heights within
//   1 cm, for the floor, the first landing and the top landing.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>

#include "rollstep/sim/online_perception.hpp"
#include "sim/cbfqp_run.hpp"
#include "sim/nmpc_run.hpp"
#include "sim/scene_match.hpp"

namespace rollstep::sim::test {
namespace {

double tiltDeg(const GroundTruth& g) {
  return std::acos(std::clamp((g.base_orientation * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0)) *
         180.0 / M_PI;
}

TEST(PerceptionClosedLoop, NmpcTrotsOnThePerceivedTerrainAndKeepsItWhileBlind) {
  SceneConfig scene;
  PlantOptions plant_options;
  plant_options.sensor_noise = SensorNoiseConfig{};
  Plant plant(scene, plant_options);
  const centroidal::RobotOcpDescription robot =
      centroidal::loadRobotOcpDescription(tachyon3Description());
  control::ControlSettings settings;
  settings.mpc.timing = control::MpcTiming::Deterministic;
  OnlinePerceptionOptions options;
  options.blind_from = 3.0;
  options.blind_until = 4.0;
  auto perception = std::make_unique<OnlinePerception>(options);
  perception->start(plant, plant.groundTruth().base_position, plant.groundTruth().base_orientation);
  const double margin = centroidal::footholdRegionMargin(robot, settings.ocp);
  StateSourceOptions source;
  source.kind = StateSourceKind::Inekf;
  source.estimator =
      estimation::loadInekfSettings(std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/estimation.yaml");
  NmpcController controller(plant, robot, settings, perception->footholdTerrain(margin),
                            planning::GaitKind::Trot, planning::BaseVelocityCommand{0.15, 0, 0},
                            source, options.perception.regions.directions);
  controller.setPerception(std::move(perception), margin);
  const OnlinePerception& p = *controller.perception();
  const control::ControlPipeline& pipeline = controller.pipeline();
  PlantCommand command = plant.command();
  double max_tilt = 0.0;
  std::uint64_t terrains_at_blind = 0, version_at_blind = 0;
  double x_at_blind = 0.0;
  bool checked_blind = false;
  const auto wall0 = std::chrono::steady_clock::now();
  while (plant.time() < 6.0 - 1e-9) {
    const double t = plant.time();
    controller.compute(t, plant.sensors(), command);
    plant.setCommand(command);
    plant.step();
    max_tilt = std::max(max_tilt, tiltDeg(plant.groundTruth()));
    // Blind from 3.0 s: the scans from 3.0 to 3.9 s build nothing. The last good terrain
    // (from 2.9 s) reaches the real-time side with a solution by about 3.0 s.
    if (terrains_at_blind == 0 && t >= 3.05) {
      terrains_at_blind = p.terrainCount();
      version_at_blind = pipeline.terrainVersion();
      x_at_blind = plant.groundTruth().base_position.x();
    }
    if (!checked_blind && t >= 3.99) {
      checked_blind = true;
      EXPECT_EQ(p.terrainCount(), terrains_at_blind) << "a blind scan built a terrain";
      EXPECT_EQ(pipeline.terrainVersion(), version_at_blind) << "the terrain changed while blind";
      EXPECT_GT(plant.groundTruth().base_position.x() - x_at_blind, 0.08) << "stopped while blind";
    }
  }
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  const OnlinePerceptionCounters& c = p.counters();
  const Eigen::Vector3d end = plant.groundTruth().base_position;
  std::printf(
      "nmpc flat trot 0.15 m/s on perception: end (%.3f, %.3f) m, tilt max %.2f deg, %llu scans, "
      "%llu terrains, %llu kept (%llu no finite point), %llu handed over, %llu QP fallbacks, "
      "map+segmentation mean %.1f ms; %.1f s wall\n",
      end.x(), end.y(), max_tilt, static_cast<unsigned long long>(c.scans),
      static_cast<unsigned long long>(c.terrains), static_cast<unsigned long long>(c.kept),
      static_cast<unsigned long long>(c.non_finite),
      static_cast<unsigned long long>(pipeline.counters().terrain_updates),
      static_cast<unsigned long long>(pipeline.counters().qp_fallbacks),
      c.total_update_ms / std::max<double>(1.0, static_cast<double>(c.scans)), wall);
  EXPECT_TRUE(checked_blind);
  EXPECT_EQ(c.scans, 59u);
  EXPECT_EQ(c.non_finite, 10u);  // 3.0, 3.1, ..., 3.9 s
  EXPECT_EQ(c.kept, 10u);
  EXPECT_EQ(c.terrains, 50u);  // the start's and 49 good scans
  EXPECT_GE(pipeline.counters().terrain_updates, 40u);
  EXPECT_EQ(controller.terrainsRefused(), 0u);
  // On the scene's ground truth the same run ends at x = 0.857 m (0 QP fallbacks).
  EXPECT_GT(end.x(), 0.75);
  EXPECT_LT(std::abs(end.y()), 0.05);
  EXPECT_LT(max_tilt, 5.0);
  EXPECT_EQ(pipeline.counters().qp_fallbacks, 0u);
  EXPECT_EQ(pipeline.counters().solutions_rejected, 0u);
}

TEST(PerceptionClosedLoop, BaselineClimbsStep20OnThePerceivedTerrain) {
  CbfQpScenario sc;
  sc.scene = "step20";
  sc.command.v_x = 0.15;
  sc.duration = 22.0;
  sc.perception = true;
  const CbfQpOutcome o = runCbfQp(sc);
  std::printf("cbfqp step20 0.15 m/s on perception: %s; %llu terrains handed over\n",
              describe(o).c_str(), static_cast<unsigned long long>(o.counters.terrain_updates));
  // On the scene's ground truth (cbfqp_closed_loop_test): traverse 12.97 s, 0 fallbacks.
  EXPECT_GE(o.counters.terrain_updates, 200u);
  // Roll: the baseline has a transient where a front corner wheel steps down the block
  // while the other trot group lifts off on the clock (its late touch-down keeps the late
  // foot in swing, but nothing waits for it) and only two wheels bear the body. It is in
  // this run since the start's blind-zone fill (session 23: 20.9 deg at 13.25 s, up to 4 deg
  // before) and, with or without the fill, in 1 of 30 randomized perception trials (16.2 and
  // 20.2 deg); a fall tilts beyond 45 deg.
  EXPECT_LT(o.max_roll_deg, 25.0);
  EXPECT_LT(o.max_pitch_deg, 8.0);
  EXPECT_GT(o.min_body_clearance, 0.05);
  EXPECT_LE(o.max_joint_limit_violation, 1e-3) << o.worst_joint;
  EXPECT_GT(o.max_mf_wheel_z, 0.26);  // MF rolled on the block
  ASSERT_GT(o.traverse_start, 0.0);
  ASSERT_GT(o.traverse_end, o.traverse_start);  // MR came down beyond it
  EXPECT_LT(o.traverse_end - o.traverse_start, 16.0);
  EXPECT_GT(o.end.x(), 2.9);
  EXPECT_NEAR(o.end.z(), 0.375, 0.03);
  EXPECT_LE(o.counters.qp_fallbacks, 20u);
}

TEST(PerceptionClosedLoop, BaselineClimbsStairs2OnThePerceivedTerrainWhoseRegionsMatchTheScene) {
  SceneConfig config = loadScene("stairs2");
  CbfQpScenario sc;
  sc.scene = "stairs2";
  sc.command.v_x = 0.15;
  sc.duration = 30.0;  // down the far edge by 28.5 s
  sc.perception = true;
  // The design sensor's range noise (config/lidar.yaml: 5 mm). With the built-in default
  // (1 cm) the risers' points smear two cells into the floor in front of them: the rising
  // edges come out 4 cm off (IoU and heights still within bounds).
  sc.perception_options.lidar.range_noise = 0.005;
  // On the first landing, 0.5 m before the second rise (where the test that places the
  // sensor along the climb looks too): the floor behind, both rises and the top landing ahead.
  const double look_x = sceneNumber(config, "start_x") + sceneNumber(config, "step1_length") - 0.5;
  Approach seen;
  double seen_at = -1.0;
  sc.observe = [&](const Plant& plant, const CbfQpController& controller) {
    if (seen_at >= 0.0 || plant.groundTruth().base_position.x() < look_x) return;
    seen_at = plant.time();
    const OnlinePerception& p = *controller.perception();
    EXPECT_EQ(p.lastStatus(), perception::PerceptionStatus::Ok);
    seen = evaluate(config, p.perception(), p.lidar().lastPose().translation().x(),
                    "stairs2 driven by the baseline");
  };
  const CbfQpOutcome o = runCbfQp(sc);
  std::printf("cbfqp stairs2 0.15 m/s on perception: %s; %llu terrains handed over\n",
              describe(o).c_str(), static_cast<unsigned long long>(o.counters.terrain_updates));
  // The regions on the way up.
  ASSERT_GT(seen_at, 0.0) << "never reached x = " << look_x;
  ASSERT_EQ(seen.size(), 3u);
  expectMatch(seen[0], "floor");
  expectMatch(seen[1], "first landing");
  expectMatch(seen[2], "top landing");
  // The climb: up both rises, over the top and down the far edge, upright, joints inside
  // their limits up to MuJoCo's soft-limit overshoot (the experiments' criterion, 0.01 rad:
  // the MF hip reaches its limit on the second rise) (on the scene's ground truth:
  // traverse 22.75 s, 0 QP fallbacks).
  EXPECT_GE(o.counters.terrain_updates, 250u);
  EXPECT_LT(o.max_roll_deg, 8.0);
  EXPECT_LT(o.max_pitch_deg, 10.0);
  EXPECT_GT(o.min_body_clearance, 0.05);
  EXPECT_LE(o.max_joint_limit_violation, 0.01) << o.worst_joint;
  EXPECT_GT(o.max_mf_wheel_z, 0.40);  // MF rolled on the top landing
  ASSERT_GT(o.traverse_start, 0.0);
  ASSERT_GT(o.traverse_end, o.traverse_start);  // MR came down beyond the top landing
  EXPECT_GT(o.end.x(), sceneNumber(config, "start_x") + sceneNumber(config, "step1_length") +
                           sceneNumber(config, "step2_length") + 0.5);
  EXPECT_NEAR(o.end.z(), 0.375, 0.03);
  EXPECT_LE(o.counters.qp_fallbacks, 20u);
}

}  // namespace
}  // namespace rollstep::sim::test
