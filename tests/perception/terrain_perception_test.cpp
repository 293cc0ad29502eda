// The elevation map (fusion, moving, no allocation after construction), the pipeline's
// status on bad data (the terrain is kept), and the settings file.
#include "rollstep/perception/terrain_perception.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <utility>

#include "common/alloc_counter.hpp"
#include "perception/synthetic_terrain.hpp"

namespace rollstep::perception {
namespace {

const Eigen::Vector3d kSensor(0.0, 0.0, 3.0);

Eigen::Isometry3d sensorPose(const Eigen::Vector3d& at = kSensor) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = at;
  return pose;
}

PerceptionSettings syntheticSettings() {
  PerceptionSettings s;
  s.map.visibility_cleanup = false;
  return s;
}

TEST(ElevationMap, FusesRepeatedNoisyPointsToTheMeanWithShrinkingVariance) {
  ElevationMap map;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<Eigen::Vector3d> pts(1);
  const double sigma = 0.005 + 0.002 * 2.9;  // the point's standard deviation at 2.9 m
  int r = 0, c = 0;
  ASSERT_TRUE(map.cellOf({0.011, 0.013}, r, c));
  for (int k = 0; k < 400; ++k) {
    pts[0] = Eigen::Vector3d(0.011, 0.013, 0.10 + noise(rng)) - kSensor;
    map.update(pts, sensorPose());
    if (k == 9) {  // ten fused points: a tenth of one point's variance
      EXPECT_NEAR(map.variance(r, c), sigma * sigma / 10, 0.05 * sigma * sigma / 10);
    }
  }
  EXPECT_NEAR(map.height(r, c), 0.10, 0.003);
  EXPECT_FLOAT_EQ(map.variance(r, c), 1e-6f);  // the floor
  EXPECT_EQ(map.validCells(), 1);
}

TEST(ElevationMap, AHigherSurfaceReplacesAndALowerOutlierOnlyInflatesTheVariance) {
  ElevationMap map;
  std::vector<Eigen::Vector3d> pts{Eigen::Vector3d(0.5, 0.5, 0.0) - kSensor};
  map.update(pts, sensorPose());
  int r = 0, c = 0;
  ASSERT_TRUE(map.cellOf({0.5, 0.5}, r, c));
  pts[0].z() = 0.2 - kSensor.z();  // a box appeared: 20 cm higher
  map.update(pts, sensorPose());
  EXPECT_FLOAT_EQ(map.height(r, c), 0.2f);
  const float v = map.variance(r, c);
  pts[0].z() = -0.3 - kSensor.z();  // a low outlier
  map.update(pts, sensorPose());
  EXPECT_FLOAT_EQ(map.height(r, c), 0.2f);
  EXPECT_GT(map.variance(r, c), v);
}

TEST(ElevationMap, VisibilityCleanupClearsCellsARayPassedThrough) {
  ElevationMap map;
  map.setCell(100, 125, 0.5f, 1e-4f);  // a phantom 50 cm obstacle at x = 0.51, y = 0.01
  const Eigen::Vector2d phantom = map.cellCenter(100, 125);
  // A ray from a sensor 0.3 m up at the origin to the floor 1.5 m ahead passes below it.
  const Eigen::Vector3d sensor(0.0, phantom.y(), 0.3);
  std::vector<Eigen::Vector3d> pts{Eigen::Vector3d(1.5, phantom.y(), 0.0) - sensor};
  const MapUpdateStats stats = map.update(pts, sensorPose(sensor));
  EXPECT_EQ(stats.cleared, 1);
  EXPECT_TRUE(std::isnan(map.height(100, 125)));
}

TEST(ElevationMap, MovesWithTheRobotKeepingWorldCells) {
  ElevationMap map;
  std::vector<Eigen::Vector3d> pts{Eigen::Vector3d(0.51, -0.33, 0.07) - kSensor};
  map.update(pts, sensorPose());
  ASSERT_TRUE(map.moveTo({1.0, 0.5}));
  int r = 0, c = 0;
  ASSERT_TRUE(map.cellOf({0.51, -0.33}, r, c));
  EXPECT_FLOAT_EQ(map.height(r, c), 0.07f);
  EXPECT_EQ(map.validCells(), 1);
  ASSERT_TRUE(map.moveTo({5.0, 0.5}));  // the point leaves the map
  EXPECT_EQ(map.validCells(), 0);
  EXPECT_FALSE(map.moveTo({std::nan(""), 0.0}));
}

TEST(ElevationMap, UncertainCellsAreForgottenOverTime) {
  ElevationMap map;
  map.setCell(10, 10, 0.0f, 1e-4f);
  map.predict(10.0);  // + 1e-3
  EXPECT_FALSE(std::isnan(map.height(10, 10)));
  map.predict(30.0);  // above max_variance 2.5e-3
  EXPECT_TRUE(std::isnan(map.height(10, 10)));
}

TEST(ElevationMap, FootprintFillsOnlyEmptyCellsOnThePlaneOfTheContacts) {
  ElevationMap map;
  map.setCell(100, 100, 0.5f, 1e-4f);  // a measured cell under the robot is kept
  // Four contacts on the plane z = 0.1 + 0.2 x.
  const std::vector<Eigen::Vector3d> contacts{
      {-0.3, -0.2, 0.04}, {0.3, -0.2, 0.16}, {0.3, 0.2, 0.16}, {-0.3, 0.2, 0.04}};
  const int filled = map.fillFootprint(contacts.data(), 4, 0.1, 1e-4);
  // (0.6 + 0.2) x (0.4 + 0.2) m of 2 cm cells, less the measured one.
  EXPECT_NEAR(filled, 40 * 30 - 1, 40 + 30);
  EXPECT_FLOAT_EQ(map.height(100, 100), 0.5f);
  int r = 0, c = 0;
  ASSERT_TRUE(map.cellOf({0.35, 0.05}, r, c));
  EXPECT_NEAR(map.height(r, c), 0.1 + 0.2 * map.cellCenter(r, c).x(), 1e-6);
  ASSERT_TRUE(map.cellOf({0.45, 0.05}, r, c));
  EXPECT_TRUE(std::isnan(map.height(r, c)));  // beyond the margin
  const std::vector<Eigen::Vector3d> bad{{std::nan(""), 0, 0}};
  EXPECT_EQ(map.fillFootprint(bad.data(), 1, 0.1, 1e-4), 0);
}

TEST(ElevationMap, BlindZoneIsFilledOnlyUpToLevelGroundSeenBeyondIt) {
  // A sensor over (0.5, 0) that sees the ground from 0.6 m on (its lowest beam's ring), the
  // robot standing on the plane z = 0.1 x. Seen beyond the ring: that plane, except a step
  // 0.2 m up in the +y sector (80 to 100 deg) and nothing at all in the -y sector.
  ElevationMap map;
  const Eigen::Vector2d sensor(0.5, 0.0);
  const auto azimuthDeg = [&](const Eigen::Vector2d& p) {
    return std::atan2(p.y() - sensor.y(), p.x() - sensor.x()) * 180 / M_PI;
  };
  for (int r = 0; r < map.size(); ++r) {
    for (int c = 0; c < map.size(); ++c) {
      const Eigen::Vector2d p = map.cellCenter(r, c);
      const double d = (p - sensor).norm(), a = azimuthDeg(p);
      if (d < 0.6 || d > 1.2 || (a > -100 && a < -80)) continue;
      const double step = a > 80 && a < 100 ? 0.2 : 0.0;
      map.setCell(r, c, static_cast<float>(0.1 * p.x() + step), 1e-4f);
    }
  }
  const std::vector<Eigen::Vector3d> contacts{
      {-0.3, -0.2, -0.03}, {0.3, -0.2, 0.03}, {0.3, 0.2, 0.03}, {-0.3, 0.2, -0.03}};
  const int measured = map.validCells();
  std::vector<float> before = map.heights();
  int filled = 0;
  {
    rollstep::test::AllocationGuard guard;
    filled = map.fillBlindZone(sensor, contacts.data(), 4, 1.5, 0.04, 2e-4);
    EXPECT_EQ(guard.count(), 0u);
  }
  EXPECT_EQ(map.validCells(), measured + filled);
  // The disc of 0.6 m less the two 20 deg sectors: the step's widened by the 2 deg of
  // neighbours that bound each sector on either side, the unseen one narrowed by as much
  // (its edges are bounded by the ground seen beside them): 320 / 360 of pi 0.36 m^2 in
  // 4 cm^2 cells.
  EXPECT_NEAR(filled, 320.0 / 360 * M_PI * 0.36 / 4e-4, 40);
  const auto heightAt = [&](double x, double y) {
    int r = 0, c = 0;
    EXPECT_TRUE(map.cellOf({x, y}, r, c));
    return map.height(r, c);
  };
  const auto cellX = [&](double x, double y) {
    int r = 0, c = 0;
    map.cellOf({x, y}, r, c);
    return map.cellCenter(r, c).x();
  };
  for (const Eigen::Vector2d& p : {Eigen::Vector2d(0.95, 0.0), Eigen::Vector2d(0.1, 0.2),
                                   Eigen::Vector2d(0.5, 0.0), Eigen::Vector2d(0.3, -0.45)}) {
    EXPECT_NEAR(heightAt(p.x(), p.y()), 0.1 * cellX(p.x(), p.y()), 1e-6) << p.transpose();
  }
  EXPECT_TRUE(std::isnan(heightAt(0.5, 0.4)));   // before the step: unknown
  EXPECT_TRUE(std::isnan(heightAt(0.5, -0.4)));  // nothing seen that way
  EXPECT_TRUE(std::isnan(heightAt(1.9, 0.0)));   // beyond the seen ring
  // Measured cells are kept.
  for (std::size_t i = 0; i < before.size(); ++i) {
    if (!std::isnan(before[i])) {
      ASSERT_EQ(map.heights()[i], before[i]);
    }
  }
  // Nothing measured within the radius, or bad arguments: nothing filled.
  ElevationMap again;
  for (std::size_t i = 0; i < before.size(); ++i) {
    again.setCell(static_cast<int>(i) / map.size(), static_cast<int>(i) % map.size(), before[i],
                  std::isnan(before[i]) ? NAN : 1e-4f);
  }
  EXPECT_EQ(again.fillBlindZone(sensor, contacts.data(), 4, 0.55, 0.04, 2e-4), 0);
  EXPECT_EQ(again.fillBlindZone({NAN, 0.0}, contacts.data(), 4, 1.5, 0.04, 2e-4), 0);
  EXPECT_EQ(again.fillBlindZone(sensor, contacts.data(), 0, 1.5, 0.04, 2e-4), 0);
  EXPECT_EQ(again.fillBlindZone(sensor, contacts.data(), 4, 1.5, -0.1, 2e-4), 0);
  EXPECT_EQ(again.fillBlindZone(sensor, contacts.data(), 4, 1.5, 0.04, 0.0), 0);
  EXPECT_EQ(again.validCells(), measured);
}

TEST(ElevationMap, UpdateMoveAndPredictDoNotAllocate) {
  ElevationMap map;
  const std::vector<Eigen::Vector3d> pts =
      test::stairsTerrain().cloud(0.02, 0.005, 0.1, kSensor, 2);
  map.update(pts, sensorPose());
  rollstep::test::AllocationGuard guard;
  map.moveTo({0.3, 0.1});
  map.update(pts, sensorPose());
  map.predict(0.1);
  EXPECT_EQ(guard.count(), 0u);
}

// Gap filling (the strips between a LiDAR's rings, the shadow behind an edge): a floor with
// every third and fourth row unseen is interpolated (a tilted floor exactly); a narrow
// shadow between a floor and a step top gets the floor's height; a wide shadow and the map
// beyond the last measured row (one side unseen) stay empty; no allocation.
TEST(ElevationMap, FillGapsInterpolatesAcrossSmallGapsOfOneSurfaceOnly) {
  ElevationMapSettings settings;
  settings.length = 1.0;
  settings.resolution = 0.02;  // 50 x 50 cells
  ElevationMap map(settings), copy(settings);
  const int n = map.size();
  const auto floor = [&](int r, int c) { return static_cast<float>(0.001 * c + 0.0005 * r); };
  for (int r = 0; r < 30; ++r) {
    if (r % 4 == 2 || r % 4 == 3) continue;  // rings: two rows in four unseen
    for (int c = 0; c < n; ++c) map.setCell(r, c, floor(r, c), 1e-4f);
  }
  for (int r = 36; r < 44; ++r) {  // a 0.2 m step top, 6 unseen rows below it (rows 30-35)
    for (int c = 0; c < n; ++c) map.setCell(r, c, 0.2f, 1e-4f);
  }
  // A wide gap (rows 44-49 unseen on a row of its own: nothing beyond) and a gap of 6
  // columns in row 0 (wider than allowed below) stay.
  for (int c = 10; c < 16; ++c) map.setCell(0, c, std::numeric_limits<float>::quiet_NaN(), 0.f);
  ASSERT_TRUE(copy.copyFrom(map));
  int filled = 0;
  {
    rollstep::test::AllocationGuard guard;
    filled = copy.fillGaps(4, 0.04);
    EXPECT_EQ(guard.count(), 0u);
  }
  EXPECT_GT(filled, 0);
  for (int r = 0; r < 30; ++r) {
    for (int c = 0; c < n; ++c) {
      const float h = copy.height(r, c);
      if (r == 0 && c >= 10 && c < 16) continue;
      ASSERT_FALSE(std::isnan(h)) << r << " " << c;
      EXPECT_NEAR(h, floor(r, c), 1e-5) << r << " " << c;  // linear: exact on a plane
    }
  }
  // The 6-row shadow below the step top (rows 30-35): wider than 4 cells, stays empty.
  for (int r = 30; r < 36; ++r) {
    for (int c = 0; c < n; ++c) EXPECT_TRUE(std::isnan(copy.height(r, c))) << r << " " << c;
  }
  // A 3-row shadow between a floor and a step top: the floor's height (the lower side).
  ElevationMap shadow(settings);
  for (int c = 0; c < n; ++c) {
    for (int r = 0; r < 10; ++r) shadow.setCell(r, c, 0.01f, 1e-4f);
    for (int r = 13; r < 20; ++r) shadow.setCell(r, c, 0.2f, 1e-4f);
  }
  EXPECT_EQ(shadow.fillGaps(4, 0.04), 3 * n);
  for (int c = 0; c < n; ++c) {
    for (int r = 10; r < 13; ++r) EXPECT_FLOAT_EQ(shadow.height(r, c), 0.01f) << r << " " << c;
  }
  for (int r = 44; r < n; ++r) {
    for (int c = 0; c < n; ++c) EXPECT_TRUE(std::isnan(copy.height(r, c))) << r << " " << c;
  }
  // The 6-row shadow with a wider limit for shadows (max_shadow_cells 8, the one-surface
  // limit still 4): the floor's height below the step; the 2-row ring gaps as before; the
  // 6-column gap of row 0 (one surface) still too wide.
  ElevationMap wide(settings);
  ASSERT_TRUE(wide.copyFrom(map));
  {
    rollstep::test::AllocationGuard guard;
    EXPECT_GT(wide.fillGaps(4, 0.04, 8), filled);
    EXPECT_EQ(guard.count(), 0u);
  }
  for (int r = 30; r < 36; ++r) {
    for (int c = 0; c < n; ++c) {
      ASSERT_FALSE(std::isnan(wide.height(r, c))) << r << " " << c;
      EXPECT_LT(wide.height(r, c), 0.1f) << r << " " << c;  // the floor side, not the top
    }
  }
  for (int c = 12; c < 14; ++c) EXPECT_TRUE(std::isnan(wide.height(0, c))) << c;
  // Row 0's 6-column gap: its cells lie in 2-row gaps along the columns (rows 0..1 are
  // measured below... row 0 is the map's edge): only a vertical or diagonal gap of at most
  // 4 cells with both ends measured may fill them; none exists (nothing below row 0).
  for (int c = 12; c < 14; ++c) EXPECT_TRUE(std::isnan(copy.height(0, c))) << c;
  // The original map is untouched; a map of another size is not copied.
  EXPECT_TRUE(std::isnan(map.height(2, 5)));
  ElevationMapSettings other = settings;
  other.length = 2.0;
  ElevationMap bigger(other);
  EXPECT_FALSE(bigger.copyFrom(map));
}

// The floor behind a block's far edge as a front LiDAR leaves it (session 24, step20 on
// perception): the riser's top row smeared a centimetre below the top, a shadow a few cells
// long, then cells 1-2 cm high at the riser's foot. The segmentation fitted the foot as a
// region of its own (a 16 deg slope over 83 cells), which kept the floor's convex pieces
// 10-25 cm away from the edge; it is the floor and joins it.
TEST(TerrainPerception, FloorAtTheFootOfARiserIsPartOfTheFloor) {
  TerrainPerception perception(syntheticSettings());
  ElevationMap& map = perception.map();
  map.moveTo(Eigen::Vector2d::Zero());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> noise(-0.004f, 0.004f);
  const double edge = 0.3;  // the block (0.156 m) ends here; the floor (0) goes on
  for (int r = 0; r < map.size(); ++r) {
    for (int c = 0; c < map.size(); ++c) {
      const double x = map.cellCenter(r, c).x() - edge;  // past the edge
      float h = 0.0f;
      if (x < 0)
        h = 0.156f;
      else if (x < 0.02)
        h = r % 3 == 0 ? 0.145f : nan;  // the riser's top row, smeared
      else if (x < 0.06)
        h = nan;  // the shadow
      else if (x < 0.10)
        h = 0.01f + 0.003f * static_cast<float>(r % 4);  // mixed cells at the foot
      map.setCell(r, c, std::isnan(h) ? h : h + noise(rng), 1e-4f);
    }
  }
  ASSERT_EQ(perception.rebuild(), PerceptionStatus::Ok);
  const Segmentation& seg = perception.segmentation();
  const int floor = seg.regionAt({1.5, 0.0});
  ASSERT_GE(floor, 0);
  for (double y = -1.0; y <= 1.0; y += 0.1) {
    EXPECT_EQ(seg.regionAt({edge + 0.09, y}), floor) << y;
  }
  // A floor piece reaches within 6 cm of the edge on the centre line.
  double nearest = 1e9;
  for (const planning::ConvexRegion& p : perception.terrain().regions()) {
    if (std::abs(p.height) > 0.01) continue;
    for (int i = 0; i <= 60; ++i) {
      const double d = 0.005 * i;  // past the edge
      if (p.margin({edge + d, 0.0}) >= 0) {
        nearest = std::min(nearest, d);
        break;
      }
    }
  }
  std::printf("floor piece from %.3f m past the edge\n", nearest);
  EXPECT_LE(nearest, 0.06 + 1e-9);
}

TEST(TerrainPerception, BadDataGivesAStatusAndKeepsTheLastTerrain) {
  TerrainPerception perception(syntheticSettings());
  EXPECT_FALSE(perception.hasTerrain());
  const std::vector<Eigen::Vector3d> good =
      test::stairsTerrain().cloud(0.01, 0.005, 0.1, kSensor, 4);
  ASSERT_EQ(perception.update(good, sensorPose(), 0.0), PerceptionStatus::Ok);
  ASSERT_TRUE(perception.hasTerrain());
  const planning::TerrainModel kept = perception.terrain();
  ASSERT_GT(kept.size(), 0);
  const auto same = [&] {
    if (perception.terrain().size() != kept.size()) return false;
    for (int i = 0; i < kept.size(); ++i) {
      if (perception.terrain().region(i).vertices != kept.region(i).vertices) return false;
    }
    return perception.terrainTime() == 0.0;
  };
  // Every ray missed: an empty scan.
  EXPECT_EQ(perception.update({}, sensorPose(), 0.1), PerceptionStatus::NoPoints);
  EXPECT_TRUE(same());
  // Returns out of range only.
  EXPECT_EQ(perception.update({Eigen::Vector3d(0, 0, 0.01)}, sensorPose(), 0.2),
            PerceptionStatus::NoPoints);
  EXPECT_TRUE(same());
  // NaN points.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(perception.update(std::vector<Eigen::Vector3d>(100, Eigen::Vector3d(nan, 0, 0)),
                              sensorPose(), 0.3),
            PerceptionStatus::NonFinite);
  EXPECT_TRUE(same());
  // A NaN pose.
  EXPECT_EQ(perception.update(good, sensorPose(Eigen::Vector3d(nan, 0, 3)), 0.4),
            PerceptionStatus::InvalidPose);
  EXPECT_TRUE(same());
  EXPECT_STREQ(toString(perception.lastStatus()), "sensor pose not finite");
  // No planar region: rubble (every cell a random height) on a fresh map.
  TerrainPerception fresh(syntheticSettings());
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uni(0.0, 0.5);
  std::vector<Eigen::Vector3d> rubble;
  for (double y = -1.99; y < 2.0; y += 0.02) {
    for (double x = -1.99; x < 2.0; x += 0.02)
      rubble.push_back(Eigen::Vector3d(x, y, uni(rng)) - kSensor);
  }
  EXPECT_EQ(fresh.update(rubble, sensorPose(), 0.0), PerceptionStatus::NoPlanarRegion);
  EXPECT_FALSE(fresh.hasTerrain());
  // ... and on the map that had terrain, rubble fused over it keeps the old terrain.
  perception.map().clear();
  EXPECT_EQ(perception.update(rubble, sensorPose(), 0.5), PerceptionStatus::NoPlanarRegion);
  EXPECT_TRUE(same());
}

TEST(PerceptionSettings, FileRoundTripsAndErrorsNameLineAndKey) {
  PerceptionSettings s;
  s.map.resolution = 0.03;
  s.segmentation.window_half = 3;
  s.regions.margin = 0.05;
  s.map.visibility_cleanup = false;
  const PerceptionSettings back = parsePerceptionSettings(toYaml(s), "round trip");
  EXPECT_EQ(back.map.resolution, 0.03);
  EXPECT_EQ(back.segmentation.window_half, 3);
  EXPECT_EQ(back.regions.margin, 0.05);
  EXPECT_FALSE(back.map.visibility_cleanup);
  EXPECT_EQ(toYaml(back), toYaml(s));
  const auto error = [](const char* text) {
    try {
      parsePerceptionSettings(text, "p.yaml");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(
      error("map:\n  resolutoin: 0.02\n"),
      "perception settings 'p.yaml': line 2: unknown key 'map.resolutoin' (known in map: length, "
      "resolution, sensor_noise, range_noise_slope, gate, process_noise, max_variance, "
      "min_variance, "
      "visibility_cleanup, visibility_stride, visibility_margin, max_range, min_range)");
  EXPECT_EQ(error("map:\n  gate: 3\nsegmentation:\n  max_residual: -1\n"),
            "perception settings 'p.yaml': line 4: segmentation.max_residual = -1: must be > 0");
  // The value as given (shortest round-trip text), not rounded to six decimals: a tiny
  // negative noise or a variance bound below the floor must not read as 0.000000.
  EXPECT_EQ(error("map:\n  sensor_noise: -1e-9\n"),
            "perception settings 'p.yaml': line 2: map.sensor_noise = -1e-09: must be in (0, 1] m");
  EXPECT_EQ(error("map:\n  min_variance: 1e-6\n  max_variance: 1e-7\n"),
            "perception settings 'p.yaml': line 3: map.max_variance = 1e-07: must be > "
            "min_variance");
  EXPECT_EQ(error("regions:\n  cover_fraction: 1.0000000000000002\n"),
            "perception settings 'p.yaml': line 2: regions.cover_fraction = 1.0000000000000002: "
            "must be in (0, 1]");
  EXPECT_EQ(error("regions:\n  margin: .nan\n"),
            "perception settings 'p.yaml': line 2: regions.margin: .nan is not finite");
  EXPECT_EQ(error("lidar: {}\n"),
            "perception settings 'p.yaml': line 1: unknown key 'lidar' (known: map, segmentation, "
            "regions, closed_loop)");
  EXPECT_EQ(error("map:\n  gate: 3\n  gate: 4\n"),
            "perception settings 'p.yaml': line 3: map.gate: given twice (first on line 2)");
  // The shipped file holds the defaults.
  const PerceptionSettings shipped = loadPerceptionSettings(ROLLSTEP_CONFIG_DIR "/perception.yaml");
  EXPECT_EQ(toYaml(shipped), toYaml(PerceptionSettings{}));
}

// The closed-loop glue's parameters (sim::OnlinePerception, the controllers): read, written
// back, and each range checked at its line; the constructor refuses them too.
TEST(PerceptionSettings, ClosedLoopKeysAreReadAndRangeChecked) {
  const PerceptionSettings s = parsePerceptionSettings(
      "closed_loop:\n  warmup_scans: 3\n  footprint_margin: 0.2\n  footprint_variance: 4e-4\n"
      "  blind_zone_radius: 0.8\n  level_max_tilt_deg: 1.5\n  level_height_tolerance: 0.005\n  "
      "seam_probe_cells: 3\n"
      "  seam_height_tolerance: 0.01\n  collision_capacity: 32\n",
      "c.yaml");
  const ClosedLoopSettings& c = s.closed_loop;
  EXPECT_EQ(c.warmup_scans, 3);
  EXPECT_EQ(c.footprint_margin, 0.2);
  EXPECT_EQ(c.footprint_variance, 4e-4);
  EXPECT_EQ(c.blind_zone_radius, 0.8);
  EXPECT_EQ(c.level_max_tilt_deg, 1.5);
  EXPECT_EQ(c.level_height_tolerance, 0.005);
  EXPECT_EQ(c.seam_probe_cells, 3);
  EXPECT_EQ(c.seam_height_tolerance, 0.01);
  EXPECT_EQ(c.collision_capacity, 32);
  EXPECT_EQ(toYaml(parsePerceptionSettings(toYaml(s), "round trip")), toYaml(s));
  // Untouched sections keep their defaults.
  EXPECT_EQ(s.map.resolution, ElevationMapSettings{}.resolution);

  const auto error = [](const std::string& text) {
    try {
      parsePerceptionSettings(text, "c.yaml");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string head = "perception settings 'c.yaml': ";
  EXPECT_EQ(error("closed_loop:\n  warmup: 3\n"),
            head +
                "line 2: unknown key 'closed_loop.warmup' (known in closed_loop: warmup_scans, "
                "footprint_margin, footprint_variance, blind_zone_radius, level_max_tilt_deg, "
                "level_height_tolerance, seam_probe_cells, seam_height_tolerance, "
                "collision_capacity)");
  EXPECT_EQ(error("closed_loop:\n  warmup_scans: 2.5\n"),
            head + "line 2: closed_loop.warmup_scans: expected an integer, got '2.5'");
  EXPECT_EQ(error("closed_loop:\n  collision_capacity: 8\n  collision_capacity: 9\n"),
            head + "line 3: closed_loop.collision_capacity: given twice (first on line 2)");
  EXPECT_EQ(error("closed_loop: 3\n"),
            head + "line 1: closed_loop: expected a mapping, got a value");
  const std::pair<const char*, const char*> ranges[] = {
      {"warmup_scans: 0", "warmup_scans = 0: must be 1 to 100"},
      {"warmup_scans: 101", "warmup_scans = 101: must be 1 to 100"},
      {"footprint_margin: -0.01", "footprint_margin = -0.01: must be in [0, 1] m"},
      {"footprint_variance: 0", "footprint_variance = 0: must be in (0, 1] m^2"},
      {"blind_zone_radius: 5.5", "blind_zone_radius = 5.5: must be in [0, 5] m"},
      {"level_max_tilt_deg: 90", "level_max_tilt_deg = 90: must be in [0, 90) deg"},
      {"level_height_tolerance: -1e-9", "level_height_tolerance = -1e-09: must be in [0, 1) m"},
      {"seam_probe_cells: 0", "seam_probe_cells = 0: must be 1 to 50"},
      {"seam_height_tolerance: 1", "seam_height_tolerance = 1: must be in [0, 1) m"},
      {"collision_capacity: 0", "collision_capacity = 0: must be 1 to 1000"},
      {"collision_capacity: 1001", "collision_capacity = 1001: must be 1 to 1000"},
  };
  for (const auto& [line, message] : ranges) {
    // The offending key on line 4, after valid ones.
    const std::string got = error(std::string("map:\n  gate: 3\nclosed_loop:\n  ") + line + "\n");
    EXPECT_EQ(got, head + "line 4: closed_loop." + message) << line;
  }
  // Settings built in code go through the same checks.
  PerceptionSettings bad;
  bad.closed_loop.warmup_scans = 0;
  EXPECT_THROW(TerrainPerception{bad}, std::invalid_argument);
}

}  // namespace
}  // namespace rollstep::perception
