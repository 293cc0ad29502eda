// The sideways part of a command held back while a foot crosses a step: step20's block on
// its default 3 m width, crossed with a forward and a sideways command (the path meets the
// block's far corner), a sideways command towards a block's side, and level ground.
#include "rollstep/planning/sideways_at_steps.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using Eigen::Vector2d;
using namespace rollstep;

// Tachyon 3's wheels in the body frame (no hip abduction: each wheel stays beside its hip).
const std::vector<Vector2d> kFeet{{0.33, 0.22},  {0.33, 0.0},  {0.33, -0.22},
                                  {-0.33, 0.22}, {-0.33, 0.0}, {-0.33, -0.22}};
constexpr double kMargin = 0.085;

planning::TerrainModel blockTerrain() {
  return planning::terrainFromBoxes({-5.0, 10.0, -5.0, 5.0, 0.0}, 0.0,
                                    {{1.0, 2.2, -1.5, 1.5, 0.20}}, kMargin);
}

lie::SE3 startPose(double x, double y, double yaw) {
  return lie::SE3(Eigen::Vector3d(x, y, 0.0),
                  Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())));
}

const planning::BaseVelocityCommand& commandAt(const std::vector<planning::TimedBaseCommand>& s,
                                               double t) {
  std::size_t k = 0;
  while (k + 1 < s.size() && t >= s[k + 1].time) ++k;
  return s[k].command;
}

struct Crossing {
  double time;
  double v_y;  // the sideways command then
};

/// Integrates the schedule as BaseReference does and returns every moment a foot passes
/// from one surface height to another, with the sideways command at that moment.
std::vector<Crossing> crossings(const std::vector<planning::TimedBaseCommand>& schedule,
                                const lie::SE3& start, const planning::TerrainModel& terrain,
                                double t_end, lie::SE3* end_pose = nullptr) {
  std::vector<Crossing> out;
  planning::BaseReference ref(terrain, {0.375, {Vector2d::Zero()}});
  ref.resetSchedule(0.0, start, schedule);
  std::vector<double> h(kFeet.size());
  for (std::size_t f = 0; f < kFeet.size(); ++f)
    h[f] = terrain.heightAt(ref.worldPoint(kFeet[f], 0));
  for (double t = 0.005; t <= t_end; t += 0.005) {
    for (std::size_t f = 0; f < kFeet.size(); ++f) {
      const double now = terrain.heightAt(ref.worldPoint(kFeet[f], t));
      if (std::abs(now - h[f]) > 0.03) out.push_back({t, commandAt(schedule, t).v_y});
      h[f] = now;
    }
  }
  if (end_pose != nullptr) *end_pose = ref.planarPoseAt(t_end);
  return out;
}

planning::SidewaysHoldConfig config() {
  planning::SidewaysHoldConfig c;
  c.reach = 0.3;
  c.max_acceleration = 0.5;
  return c;
}

TEST(SidewaysAtSteps, TheBlockIsCrossedStraightAndTheSidewaysMotionResumes) {
  const planning::TerrainModel terrain = blockTerrain();
  const std::vector<planning::TimedBaseCommand> asked{{0.0, {0.15, 0.1, 0.0}}};
  // As asked, the path meets the block's far corner: feet cross its edges moving sideways.
  const std::vector<Crossing> open = crossings(asked, startPose(0, 0, 0), terrain, 30.0);
  ASSERT_FALSE(open.empty());
  std::vector<planning::SidewaysHold> holds;
  const std::vector<planning::TimedBaseCommand> held =
      planning::holdSidewaysAtSteps(asked, startPose(0, 0, 0), terrain, kFeet, config(), &holds);
  ASSERT_FALSE(holds.empty());
  lie::SE3 end;
  const std::vector<Crossing> crossed = crossings(held, startPose(0, 0, 0), terrain, 30.0, &end);
  // Every foot goes up and comes down again (onto the block and off it): at least 12
  // crossings, none of them moving sideways; the forward speed is never changed.
  EXPECT_GE(crossed.size(), 12u);
  for (const Crossing& c : crossed) EXPECT_EQ(c.v_y, 0.0) << "a foot crosses at t = " << c.time;
  for (const planning::TimedBaseCommand& c : held) {
    EXPECT_EQ(c.command.v_x, 0.15);
    EXPECT_GE(c.command.v_y, 0.0);
    EXPECT_LE(c.command.v_y, 0.1);
  }
  // The sideways speed changes at most 0.5 m/s^2 (0.01 m/s per 0.02 s step).
  for (std::size_t k = 1; k < held.size(); ++k) {
    EXPECT_LE(std::abs(held[k].command.v_y - held[k - 1].command.v_y), 0.01 + 1e-12);
  }
  // Past the block it moves sideways again as asked: all of the command at the end, and the
  // robot beyond the block, on the floor, to the left of where it crossed.
  EXPECT_EQ(held.back().command.v_y, 0.1);
  EXPECT_GT(end.translation.x(), 2.2 + 0.33 + kMargin);
  EXPECT_GT(end.translation.y(), 1.0);
  // The holds begin before the first crossing and one ends after the last.
  EXPECT_LT(holds.front().start, crossed.front().time);
  EXPECT_GT(holds.back().end, crossed.back().time);
}

TEST(SidewaysAtSteps, ASidewaysCommandStopsBesideABlocksSide) {
  const planning::TerrainModel terrain = blockTerrain();
  // Beside the block's middle, moving to the right towards its side (y = 1.5 m).
  const lie::SE3 start = startPose(1.6, 2.2, 0.0);
  const std::vector<planning::TimedBaseCommand> asked{{0.0, {0.0, -0.1, 0.0}}};
  ASSERT_FALSE(crossings(asked, start, terrain, 10.0).empty());
  std::vector<planning::SidewaysHold> holds;
  const std::vector<planning::TimedBaseCommand> held =
      planning::holdSidewaysAtSteps(asked, start, terrain, kFeet, config(), &holds);
  lie::SE3 end;
  EXPECT_TRUE(crossings(held, start, terrain, 30.0, &end).empty());
  ASSERT_EQ(holds.size(), 1u);
  EXPECT_EQ(held.back().command.v_y, 0.0);
  // It stopped short of the side, the right wheels more than the wheel band away from it.
  EXPECT_GT(end.translation.y() - 0.22, 1.5 + kMargin);
  EXPECT_LT(end.translation.y() - 0.22, 1.5 + 0.3 + kMargin + 0.05);
  // Moving away from the side is not held.
  const std::vector<planning::TimedBaseCommand> away{{0.0, {0.0, 0.1, 0.0}}};
  holds.clear();
  const std::vector<planning::TimedBaseCommand> free =
      planning::holdSidewaysAtSteps(away, start, terrain, kFeet, config(), &holds);
  EXPECT_TRUE(holds.empty());
  for (const planning::TimedBaseCommand& c : free) EXPECT_EQ(c.command.v_y, 0.1);
}

TEST(SidewaysAtSteps, UnchangedOnLevelGroundOrWithoutASidewaysCommand) {
  // (Scanned for 20 s: the path stays well inside the floor, whose border is an edge.)
  const planning::TerrainModel flat = planning::terrainFromBoxes({-9, 9, -9, 9, 0}, 0.0, {});
  const std::vector<planning::TimedBaseCommand> asked{{0.0, {0.15, 0.1, 0.2}},
                                                      {3.0, {-0.1, -0.05, 0.0}}};
  planning::SidewaysHoldConfig c = config();
  c.scan_time = 20.0;
  const std::vector<planning::TimedBaseCommand> same =
      planning::holdSidewaysAtSteps(asked, startPose(0, 0, 0.3), flat, kFeet, c, nullptr);
  ASSERT_EQ(same.size(), asked.size());
  for (std::size_t k = 0; k < asked.size(); ++k) {
    EXPECT_EQ(same[k].time, asked[k].time);
    EXPECT_EQ(same[k].command.v_y, asked[k].command.v_y);
  }
  const std::vector<planning::TimedBaseCommand> straight{{0.0, {0.3, 0.0, 0.0}}};
  EXPECT_EQ(planning::holdSidewaysAtSteps(straight, startPose(0, 0, 0), blockTerrain(), kFeet,
                                          config(), nullptr)
                .size(),
            1u);
}

TEST(SidewaysAtSteps, BadInputThrowsNamingIt) {
  const planning::TerrainModel terrain = blockTerrain();
  const auto expectNaming = [&](const std::vector<planning::TimedBaseCommand>& s,
                                const planning::SidewaysHoldConfig& c, const std::string& what) {
    try {
      planning::holdSidewaysAtSteps(s, startPose(0, 0, 0), terrain, kFeet, c, nullptr);
      ADD_FAILURE() << "no exception, expected " << what;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  expectNaming({}, config(), "schedule.size()");
  expectNaming({{0.5, {0.1, 0.1, 0.0}}}, config(), "schedule[0].time");
  expectNaming({{0.0, {0.1, 0.1, 0.0}}, {0.0, {0.1, 0.0, 0.0}}}, config(), "schedule[1].time");
  expectNaming({{0.0, {0.1, std::numeric_limits<double>::quiet_NaN(), 0.0}}}, config(),
               "schedule[0].command.v_y");
  planning::SidewaysHoldConfig bad = config();
  bad.resolution = 0.0;
  expectNaming({{0.0, {0.1, 0.1, 0.0}}}, bad, "resolution");
  bad = config();
  bad.reach = -1.0;
  expectNaming({{0.0, {0.1, 0.1, 0.0}}}, bad, "reach");
}

}  // namespace
