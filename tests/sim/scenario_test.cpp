// Runs and their outputs: CSV columns with units, logs that appear complete or not at
// all (full disk), arguments of runScenario, and the unwrapped yaw change.
#include "rollstep/sim/scenario.hpp"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "rollstep/common/text_file.hpp"
#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace rollstep::sim {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream s(line);
  for (std::string item; std::getline(s, item, ',');) out.push_back(item);
  return out;
}

std::string readAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Files in dir whose name does not start with '.' or does (temporaries): all of them.
std::vector<std::string> filesIn(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) {
    names.push_back(entry.path().filename().string());
  }
  return names;
}

// Every column name ends in its unit in brackets; the units are the right ones.
TEST(CsvLog, EveryColumnHasItsUnit) {
  const Plant plant{SceneConfig{}};
  const std::vector<std::string> columns = split(csvHeader(plant.layout()));
  ASSERT_EQ(columns.size(), 1u + 3 + 4 + 3 + 3 + 12 + 12 + 4 + 4 + 6 + 6 + 6 + 2 * 6 + 3 * 6 + 1);
  // name[unit]: letters and '_', then one of the known units in brackets. (No <regex>: GCC 12
  // warns falsely inside libstdc++'s regex in the sanitizer builds, which are -Werror.)
  const auto withUnit = [](const std::string& c) {
    const std::size_t open = c.find('[');
    if (open == 0 || open == std::string::npos || c.back() != ']') return false;
    for (std::size_t i = 0; i < open; ++i) {
      if (!(std::isalpha(static_cast<unsigned char>(c[i])) || c[i] == '_')) return false;
    }
    const std::string unit = c.substr(open + 1, c.size() - open - 2);
    for (const char* u : {"s", "m", "-", "m/s", "rad/s", "rad", "N", "0/1"}) {
      if (unit == u) return true;
    }
    return false;
  };
  for (const std::string& c : columns) EXPECT_TRUE(withUnit(c)) << c;
  EXPECT_FALSE(withUnit("base_vx")) << "the check itself";
  EXPECT_FALSE(withUnit("base_vx[km]")) << "the check itself";
  const auto has = [&](const std::string& name) {
    return std::find(columns.begin(), columns.end(), name) != columns.end();
  };
  for (const char* name :
       {"time[s]", "base_x[m]", "base_qw[-]", "base_vx[m/s]", "base_wz[rad/s]", "q_LF_hip[rad]",
        "q_LF_knee[m]", "cmd_RR_hip[rad]", "cmd_RR_knee[m]", "wheel_vel_LF[rad/s]",
        "cmd_wheel_RR[rad/s]", "contact_MF[0/1]", "fz_MR[N]", "foot_z_MF[m]", "fx_MF[N]",
        "fy_MR[N]", "contact_point_z_MF[m]", "body_contact_periods[-]"}) {
    EXPECT_TRUE(has(name)) << name;
  }
}

TEST(CsvLog, AppearsOnlyWhenCommittedWithAsManyValuesAsColumns) {
  const std::string dir = ::testing::TempDir() + "csvlog_commit";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string path = dir + "/log.csv";
  Plant plant(SceneConfig{});
  {
    CsvLog log(path, plant.layout());
    log.write(plant.groundTruth(), plant.command());
    EXPECT_FALSE(fs::exists(path));  // only the temporary exists while writing
  }                                  // not committed: nothing is left, not even the temporary
  EXPECT_TRUE(filesIn(dir).empty());
  {
    CsvLog log(path, plant.layout());
    StandController stand(plant.nominalCommand());
    runScenario(plant, stand, 0.05, &log, 10);
    log.commit();
  }
  EXPECT_EQ(filesIn(dir), std::vector<std::string>{"log.csv"});
  std::stringstream text(readAll(path));
  std::string line;
  std::getline(text, line);
  EXPECT_EQ(line, csvHeader(plant.layout()));
  int rows = 0;
  while (std::getline(text, line)) {
    EXPECT_EQ(split(line).size(), split(csvHeader(plant.layout())).size()) << line;
    ++rows;
  }
  EXPECT_EQ(rows, 6);  // t = 0 and every 10 ms up to 50 ms
}

TEST(RunScenario, RefusesBadArguments) {
  Plant plant(SceneConfig{});
  StandController stand(plant.nominalCommand());
  for (double duration : {std::numeric_limits<double>::quiet_NaN(),
                          std::numeric_limits<double>::infinity(), -0.1, 2e6}) {
    EXPECT_THROW(runScenario(plant, stand, duration), std::invalid_argument) << duration;
  }
  EXPECT_THROW(runScenario(plant, stand, 0.01, nullptr, 0), std::invalid_argument);
  EXPECT_EQ(plant.time(), 0.0);  // nothing was simulated
}

/// Mounts a tmpfs of `bytes` at a fresh directory; empty if that is not permitted.
std::string mountTinyDisk(const std::string& name, std::size_t bytes) {
  const std::string dir = ::testing::TempDir() + name;
  ::umount(dir.c_str());
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string size = "size=" + std::to_string(bytes);
  if (::mount("tmpfs", dir.c_str(), "tmpfs", 0, size.c_str()) != 0) return {};
  return dir;
}

// A full disk: the write fails with an error naming the file and the reason, and no
// truncated log is left (neither under its name nor as a temporary).
TEST(CsvLog, FullDiskIsAnErrorAndLeavesNothing) {
  const std::string disk = mountTinyDisk("tiny_disk_csv", 64 * 1024);
  if (disk.empty()) GTEST_SKIP() << "cannot mount a tmpfs here (needs root)";
  const std::string path = disk + "/log.csv";
  Plant plant(SceneConfig{});
  StandController stand(plant.nominalCommand());
  std::string error;
  try {
    CsvLog log(path, plant.layout());
    runScenario(plant, stand, 2.0, &log, 1);  // ~1 MB of rows into 64 kB
    log.commit();
  } catch (const OutputError& e) {
    error = e.what();
  }
  EXPECT_NE(error.find(path), std::string::npos) << error;
  EXPECT_NE(error.find("No space left"), std::string::npos) << error;
  EXPECT_TRUE(filesIn(disk).empty());
  ::umount(disk.c_str());
}

// The yaw change is the total rotation, not the end heading minus the start one wrapped
// to +-180 deg: spin the robot in the air at 20 rad/s for 0.3 s (about 344 deg).
TEST(RunScenario, YawChangeIsUnwrapped) {
  Plant plant(SceneConfig{});
  plant.reset(0.0, 0.0, 3.0, 2.0);  // facing 172 deg, 2 m up: it spins across +-180 deg
  mjData* d = plant.mujocoData();
  d->qvel[5] = 20.0;  // base angular velocity about z
  StandController stand(plant.nominalCommand());
  const RunSummary s = runScenario(plant, stand, 0.3);
  const double expected = 20.0 * 0.3;  // free flight: angular momentum is conserved
  EXPECT_NEAR(s.yaw_change, expected, 0.05 * expected);
  // Turning the other way reads negative.
  plant.reset(0.0, 0.0, -3.0, 2.0);
  d->qvel[5] = -20.0;
  EXPECT_NEAR(runScenario(plant, stand, 0.3).yaw_change, -expected, 0.05 * expected);
}

}  // namespace
}  // namespace rollstep::sim
