// The NMPC pipeline as a plant controller, short runs (label sim; also in the sanitizer
// trees): the real-time tick allocates nothing, bad states are refused, runs repeat bit
// for bit; terrains reach the pipeline, also from a perception thread beside an
// asynchronous MPC.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "common/alloc_counter.hpp"
#include "rollstep/sim/online_perception.hpp"
#include "rollstep/sim/run.hpp"
#include "sim/closed_loop_ticks.hpp"
#include "sim/nmpc_run.hpp"

namespace rollstep::sim::test {
namespace {

control::ControlSettings shortHorizon() {
  control::ControlSettings s;
  s.ocp.horizon = 40;  // 0.6 s: enough for these short checks, cheaper under sanitizers
  // One iteration per update, used 10 ms after its state: the counts below are written for
  // those (the defaults are two and 20 ms).
  s.ocp.solver.realtime_iterations = 1;
  s.mpc.latency = 0.01;
  return s;
}

/// shortHorizon() with the MPC on its own thread.
control::ControlSettings asynchronousMpc() {
  control::ControlSettings s = shortHorizon();
  s.mpc.timing = control::MpcTiming::Asynchronous;
  s.mpc.max_solution_age = 100.0;  // a slow (sanitized) MPC must not trip the watchdog
  // The gait's waits at steps' edges need a plan older than the watchdog's age: none here.
  s.ocp.step_down_max_hold = 0.0;
  s.ocp.step_up_max_hold = 0.0;
  return s;
}

/// A trot at 0.1 m/s on the flat scene: the plant and the NMPC controller driving it.
struct FlatTrot {
  explicit FlatTrot(const control::ControlSettings& settings)
      : plant(scene),
        controller(plant, centroidal::loadRobotOcpDescription(tachyon3Description()), settings,
                   terrainFromScene(scene, 0.085), planning::GaitKind::Trot,
                   planning::BaseVelocityCommand{0.1, 0, 0}) {}
  SceneConfig scene;
  Plant plant;
  NmpcController controller;
};

/// runTicks, counting the heap allocations of the controller's compute() on this thread.
std::size_t allocationsOfTicks(Controller& controller, Plant& plant, int n) {
  PlantCommand command = plant.command();
  std::size_t allocations = 0;
  for (int k = 0; k < n; ++k) {
    rollstep::test::AllocationGuard guard;
    controller.compute(plant.time(), plant.sensors(), command);
    allocations += guard.count();
    plant.setCommand(command);
    plant.step();
  }
  return allocations;
}

TEST(NmpcController, StandsAndRepeatsBitForBit) {
  NmpcScenario sc;
  sc.settings = shortHorizon();
  sc.duration = 0.3;
  const NmpcOutcome a = runNmpc(sc);
  const NmpcOutcome b = runNmpc(sc);
  std::printf("stand 0.3 s: %s\n", describe(a).c_str());
  EXPECT_LT(a.max_roll_deg, 1.0);
  EXPECT_LT(a.max_pitch_deg, 1.0);
  EXPECT_EQ(a.counters.qp_fallbacks, 0u);
  EXPECT_GE(a.counters.solutions_received, 14u);  // every 20 ms
  ASSERT_EQ(a.log.size(), b.log.size());
  EXPECT_TRUE(a.log == b.log) << "two deterministic runs differ";
}

TEST(NmpcController, TrotTickMakesNoAllocationAndRefusesBadStates) {
  SceneConfig scene;
  Plant plant(scene);
  const centroidal::RobotOcpDescription robot =
      centroidal::loadRobotOcpDescription(tachyon3Description());
  control::ControlSettings settings = shortHorizon();
  NmpcController controller(plant, robot, settings, terrainFromScene(scene, 0.085),
                            planning::GaitKind::Trot, planning::BaseVelocityCommand{0.1, 0, 0});
  runTicks(controller, plant, 30);  // warm up: first solves, first QP
  control::ControlPipeline& pipeline = controller.pipeline();
  control::JointCommand out = pipeline.makeCommand();
  // The tick itself, on the last real state moved along in time: 60 ticks span three MPC
  // solves (deterministic mode solves inside the tick) and three refinements.
  control::RobotState s = internalState(pipeline, plant.time());
  std::size_t count = 0;
  for (int k = 0; k < 60; ++k) {
    s.time += 0.001;
    rollstep::test::AllocationGuard guard;
    pipeline.tick(s, out);
    count += guard.count();
  }
  EXPECT_EQ(count, 0u) << "the real-time tick allocated";
  EXPECT_GE(pipeline.counters().solutions_received, 2u);

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

// The replay's plan log (plan.csv.gz): every adopted solution, every 5th node and the last,
// its base and contact positions as solved; recording and the log row allocate nothing.
TEST(NmpcController, PlanLogRecordsTheAdoptedSolutions) {
  SceneConfig scene;
  Plant plant(scene);
  const centroidal::RobotOcpDescription robot =
      centroidal::loadRobotOcpDescription(tachyon3Description());
  NmpcController controller(plant, robot, shortHorizon(), terrainFromScene(scene, 0.085),
                            planning::GaitKind::Trot, planning::BaseVelocityCommand{0.1, 0, 0});
  EXPECT_EQ(controller.planCsv(), "");
  controller.enablePlanLog(5, 0.06);
  PlantCommand command = plant.command();
  std::size_t allocations = 0;
  std::string extra;
  extra.reserve(2048);            // as runScenario does
  for (int k = 0; k < 60; ++k) {  // three deterministic solves, adopted; each tick logged
    rollstep::test::AllocationGuard guard;
    controller.compute(plant.time(), plant.sensors(), command);
    controller.logValues(extra);
    allocations += guard.count();
    plant.setCommand(command);
    plant.step();
  }
  EXPECT_EQ(allocations, 0u) << "recording the plans or the log row allocated in the loop";
  // The log row has a value for every column (the barrier columns named from the robot).
  const auto count = [](const std::string& text, char c) {
    return std::count(text.begin(), text.end(), c);
  };
  EXPECT_EQ(count(extra, ','), count(controller.logColumns(), ','));
  EXPECT_NE(controller.logColumns().find(",qp_active_LF[-],qp_active_MF[-]"), std::string::npos);
  const std::string csv = controller.planCsv();
  const std::size_t header_end = csv.find('\n');
  ASSERT_NE(header_end, std::string::npos);
  EXPECT_EQ(csv.substr(0, header_end)
                .rfind("solution_time[s],time[s],sequence[-],mode[-],base_x[m],base_y[m],base_z[m],"
                       "foot_LF_wheel_x[m],foot_LF_wheel_y[m],foot_LF_wheel_z[m]",
                       0),
            0u);
  // Rows: 9 per solution of 41 nodes (0, 5, ..., 40); the newest is the one in use.
  std::vector<std::vector<double>> rows;
  std::size_t at = header_end + 1;
  while (at < csv.size()) {
    const std::size_t end = csv.find('\n', at);
    std::vector<double> row;
    std::size_t p = at;
    while (p < end) {
      std::size_t q = csv.find(',', p);
      if (q == std::string::npos || q > end) q = end;
      row.push_back(std::stod(csv.substr(p, q - p)));
      p = q + 1;
    }
    rows.push_back(row);
    at = end + 1;
  }
  const control::MpcSolution& s = controller.pipeline().lastSolution();
  ASSERT_GE(rows.size(), 3u * 9u);  // the initial solution and those adopted since
  EXPECT_EQ(rows.size() % 9, 0u);
  const std::vector<double>* first_of_last = &rows[rows.size() - 9];
  EXPECT_EQ((*first_of_last)[2], static_cast<double>(s.sequence));
  EXPECT_NEAR((*first_of_last)[0], s.t0, 1e-4);
  EXPECT_NEAR(rows.back()[1], s.t0 + 40 * s.dt, 1e-4);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR((*first_of_last)[4 + i], s.xs[0][i], 5e-4);  // mm
  // Stance wheels at node 0 stand on the floor: their centres a wheel radius up.
  const int mode = static_cast<int>((*first_of_last)[3]);
  int stance = 0;
  for (int c = 0; c < 6; ++c) {
    if (((mode >> c) & 1) == 0) continue;
    ++stance;
    EXPECT_NEAR((*first_of_last)[7 + 3 * c + 2], 0.075, 5e-3) << "contact " << c;
  }
  EXPECT_GE(stance, 3);
}

// The plan log's storage is reserved for the run's duration whatever it is (no cap), and a
// caller running past it (Python stepping on) still allocates nothing: the solutions past
// the reserve are counted, not recorded.
TEST(NmpcController, PlanLogNeverAllocatesInTheLoop) {
  SceneConfig scene;
  Plant plant(scene);
  const centroidal::RobotOcpDescription robot =
      centroidal::loadRobotOcpDescription(tachyon3Description());
  NmpcController controller(plant, robot, shortHorizon(), terrainFromScene(scene, 0.085),
                            planning::GaitKind::Trot, planning::BaseVelocityCommand{0.1, 0, 0});
  const double period = shortHorizon().mpc.period;
  EXPECT_THROW(controller.enablePlanLog(5, std::nan("")), std::invalid_argument);
  EXPECT_THROW(controller.enablePlanLog(5, -1.0), std::invalid_argument);
  EXPECT_THROW(controller.enablePlanLog(5, 1e9), std::invalid_argument);  // petabytes
  controller.enablePlanLog(5, 1200.0);  // 20 minutes: more than the 10 once reserved
  EXPECT_GE(controller.planLogCapacity(), static_cast<std::size_t>(1200.0 / period) + 1);
  // A run of 0.04 s: room for the solution in use and those of two more periods (+ 1).
  controller.enablePlanLog(5, 0.04);
  ASSERT_EQ(controller.planLogCapacity(), 5u);
  // 0.2 s: about ten adopted solutions.
  EXPECT_EQ(allocationsOfTicks(controller, plant, 200), 0u) << "the plan log allocated in the loop";
  // The MPC log's records (mpc.csv) since the constructor: the initial solve and every
  // solution received, adopted or not.
  const auto& updates = controller.mpcUpdates();
  const std::size_t adopted = static_cast<std::size_t>(std::count_if(
      updates.begin(), updates.end(), [](const MpcUpdateRecord& u) { return u.adopted; }));
  EXPECT_GE(adopted, 9u);
  EXPECT_EQ(controller.planLogDropped() + 5u, adopted);
  const std::string csv = controller.planCsv();
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + 5 * 9);  // header, 5 solutions
}

// The plan log under the asynchronous timing: a simulation slower than real time (10 ms of
// wall time per 1 ms tick) gets a solution every few ticks from the MPC thread (at most one
// per period of wall time), far more often than once per period of loop time. Kept are
// exactly the adopted solutions whose state is at least half a period newer than the last
// kept one (the first: the solution in use when the log starts), no other.
TEST(NmpcController, AsynchronousPlanLogKeepsOneSolutionPerHalfPeriod) {
  const double half_period = 0.5 * asynchronousMpc().mpc.period;
  FlatTrot run(asynchronousMpc());
  NmpcController& controller = run.controller;
  constexpr double kDuration = 0.12;  // [s]
  controller.enablePlanLog(5, kDuration);
  for (long k = 0; k < std::lround(kDuration / run.plant.controlPeriod()); ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    runTicks(controller, run.plant, 1);
  }
  controller.pipeline().stop();
  ASSERT_EQ(controller.planLogDropped(), 0u);
  // The kept solutions' sequence numbers, in order, from plan.csv.
  std::vector<unsigned long long> kept;
  const std::string csv = controller.planCsv();
  for (std::size_t line = csv.find('\n') + 1; line < csv.size(); line = csv.find('\n', line) + 1) {
    const std::size_t a = csv.find(',', line), b = csv.find(',', a + 1);
    const unsigned long long sequence = std::stoull(csv.substr(b + 1));
    if (kept.empty() || kept.back() != sequence) kept.push_back(sequence);
  }
  // The rule applied to every adopted solution, in order of arrival.
  std::vector<unsigned long long> expected;
  double last_kept = 0.0;
  std::size_t adopted = 0, close = 0;
  for (const MpcUpdateRecord& u : controller.mpcUpdates()) {
    if (!u.adopted) continue;
    ++adopted;
    if (!expected.empty() && u.state_time < last_kept + half_period) {
      ++close;
      continue;
    }
    expected.push_back(u.sequence);
    last_kept = u.state_time;
  }
  std::printf("%zu solutions adopted, %zu kept, %zu within half a period of the last kept\n",
              adopted, kept.size(), close);
  EXPECT_GT(close, 0u) << "no solution came within half a period: the rule was not exercised";
  EXPECT_GE(expected.size(), 5u);
  EXPECT_EQ(kept, expected);
}

// mpc.csv's records: reserved for the run's duration, one per MPC period (deterministic)
// or per control period (asynchronous: a solution can arrive at any tick), never grown in
// the loop; past the reserve the records are counted, not kept.
TEST(NmpcController, UpdateLogNeverAllocatesInTheLoop) {
  FlatTrot run(shortHorizon());
  NmpcController& controller = run.controller;
  EXPECT_THROW(controller.reserveUpdateLog(std::nan("")), std::invalid_argument);
  EXPECT_THROW(controller.reserveUpdateLog(-1.0), std::invalid_argument);
  EXPECT_THROW(controller.reserveUpdateLog(1e12), std::invalid_argument);  // terabytes
  controller.reserveUpdateLog(7200.0);  // two hours: more than the one once reserved
  EXPECT_GE(controller.updateLogCapacity(), static_cast<std::size_t>(7200.0 / 0.02) + 1);
  // A run of 0.04 s: room for the initial solve's record and those of two more periods
  // (+ 1 for the rounding); the record made so far is kept.
  controller.reserveUpdateLog(0.04);
  ASSERT_EQ(controller.updateLogCapacity(), 5u);
  ASSERT_EQ(controller.mpcUpdates().size(), 1u);
  const MpcUpdateRecord* storage = controller.mpcUpdates().data();
  // 0.2 s: ten solutions received.
  EXPECT_EQ(allocationsOfTicks(controller, run.plant, 200), 0u)
      << "the MPC update log allocated in the loop";
  EXPECT_EQ(controller.mpcUpdates().data(), storage);
  EXPECT_EQ(controller.mpcUpdates().size(), 5u);
  const std::uint64_t received = controller.pipeline().counters().solutions_received;
  EXPECT_GE(received, 9u);
  EXPECT_EQ(controller.mpcUpdates().size() + controller.mpcUpdatesDropped(), received + 1);
}

// A run built from its spec (as `rollstep sim` and the Python Simulation build it), with
// the asynchronous timing: the recorder is sized for the run's duration at one record per
// tick, and running the whole duration neither moves nor outgrows it.
TEST(NmpcController, ARunsUpdateLogIsReservedForItsDuration) {
  RunSpec spec;
  spec.controller = ControllerKind::Nmpc;
  spec.gait = planning::GaitKind::Trot;
  spec.command = {{0.0, {0.1, 0.0, 0.0}}};
  spec.duration = 0.1;
  spec.control = asynchronousMpc();
  spec.control->mpc.period = 0.0;  // back to back: as many solutions as the thread makes
  BuiltRun run = buildRun(spec);
  ASSERT_NE(run.nmpc, nullptr);
  NmpcController& controller = *run.nmpc;
  Plant& plant = *run.plant;
  const long ticks = std::lround(spec.duration / plant.controlPeriod());
  // The initial solve's record and one per tick at most, with little to spare: a reserve
  // for a fixed hour (as once) is not the run's.
  EXPECT_GE(controller.updateLogCapacity(), static_cast<std::size_t>(ticks) + 1);
  EXPECT_LE(controller.updateLogCapacity(), static_cast<std::size_t>(ticks) + 3);
  EXPECT_EQ(controller.mpcUpdates().capacity(), controller.updateLogCapacity());
  const MpcUpdateRecord* storage = controller.mpcUpdates().data();
  runTicks(controller, plant, static_cast<int>(ticks));
  controller.pipeline().stop();
  EXPECT_EQ(controller.mpcUpdates().data(), storage);
  EXPECT_EQ(controller.mpcUpdates().capacity(), controller.updateLogCapacity());
  EXPECT_EQ(controller.mpcUpdatesDropped(), 0u);
  EXPECT_EQ(controller.mpcUpdates().size(),
            controller.pipeline().counters().solutions_received + 1);
}

// Late touch-downs (ocp.late_touchdown_tolerance): LF's measured wheel held 4 cm above
// where the internal state has it while its swing ends. When its stance is due the foot
// stays out of the contact mode (no contact consistency holding it up), its target
// descends, and the tick still allocates nothing (the schedule's landing switch, the MPC's
// solves inside the tick). Given the foot back on its surface, the stance begins.
TEST(NmpcController, ALateTouchDownStaysInSwingUntilItLands) {
  SceneConfig scene;
  Plant plant(scene);
  const centroidal::RobotOcpDescription robot =
      centroidal::loadRobotOcpDescription(tachyon3Description());
  control::ControlSettings settings = shortHorizon();
  settings.ocp.late_touchdown_tolerance = 0.01;
  NmpcController controller(plant, robot, settings, terrainFromScene(scene, 0.085),
                            planning::GaitKind::Trot, planning::BaseVelocityCommand{0.1, 0, 0});
  runTicks(controller, plant, 30);
  control::ControlPipeline& pipeline = controller.pipeline();
  const centroidal::CentroidalRobot& r = pipeline.robot();
  model::Data data(r.model());
  Eigen::Matrix3Xd feet(3, r.nc());
  constexpr int kFoot = 0;  // LF
  const auto footZ = [&](const control::RobotState& st) {
    Eigen::VectorXd q(r.nq()), v(r.nv());
    control::toModelState(st, q, v);
    Eigen::VectorXd x = Eigen::VectorXd::Zero(r.nx());
    x.head(r.nq()) = q;
    centroidal::contactPositionsOfState(r, data, x, feet);
    return feet(2, kFoot);
  };
  // The joint that lifts LF alone (by finite differences: no joint order assumed).
  control::RobotState s = internalState(pipeline, plant.time());
  int lift = -1;
  double slope = 0.0;
  for (int j = 0; j < r.nj(); ++j) {
    control::RobotState p = s;
    p.joint_position[j] += 1e-4;
    const double d = (footZ(p) - footZ(s)) / 1e-4;
    if (std::abs(d) > std::abs(slope)) {
      slope = d;
      lift = j;
    }
  }
  ASSERT_GE(lift, 0);
  // LF's measured wheel held at least 4 cm above the floor (as if it could not come down);
  // relative to the floor, not to the internal state, which blends the measurement in.
  const double held = r.contactOffset() + 0.04;
  const auto raised = [&](control::RobotState st) {
    const double z = footZ(st);
    if (z < held) st.joint_position[lift] += (held - z) / slope;
    return st;
  };
  control::JointCommand out = pipeline.makeCommand();
  // Until LF's swing has begun and ended, held up from its lift-off.
  bool swung = false, late = false;
  std::size_t allocations = 0;
  double t = plant.time();
  for (int k = 0; k < 2000 && !late; ++k) {
    t += 0.001;
    s = internalState(pipeline, t);
    if (swung) s = raised(s);
    rollstep::test::AllocationGuard guard;
    pipeline.tick(s, out);
    allocations += guard.count();
    const control::TickRecord& rec = pipeline.lastTick();
    swung = swung || ((rec.mode >> kFoot) & 1) == 0;
    late = swung && (rec.late_feet >> kFoot & 1) != 0;
  }
  ASSERT_TRUE(late) << "LF never landed late";
  EXPECT_EQ(pipeline.lastTick().mode >> kFoot & 1, 0) << "a late foot is out of the mode";
  EXPECT_GT(footZ(s), held - 1e-3);
  // Held up for 50 ms more: still in swing, its height target coming down, and the MPC's
  // plans (solved inside the tick) land it later.
  const double z0 = pipeline.reference().foot_position(2, kFoot);
  double previous = z0;
  bool planned_landing = false;
  for (int k = 0; k < 50; ++k) {
    t += 0.001;
    s = raised(internalState(pipeline, t));
    rollstep::test::AllocationGuard guard;
    pipeline.tick(s, out);
    allocations += guard.count();
    EXPECT_NE(pipeline.lastTick().late_feet >> kFoot & 1, 0) << k;
    const double z = pipeline.reference().foot_position(2, kFoot);
    EXPECT_LE(z, previous + 1e-12) << k;
    previous = z;
    const control::MpcSolution& plan = pipeline.lastSolution();
    if (pipeline.lastTick().new_solution && (plan.modes.front() >> kFoot & 1) == 0) {
      planned_landing = std::any_of(plan.modes.begin(), plan.modes.end(),
                                    [](int m) { return (m >> kFoot & 1) == 1; });
    }
  }
  EXPECT_EQ(allocations, 0u) << "the real-time tick allocated";
  EXPECT_LT(previous, z0 - 0.01);
  EXPECT_TRUE(planned_landing) << "no MPC plan delayed LF's stance";
  EXPECT_GE(pipeline.counters().late_touchdown_ticks, 51u);
  // On the floor: the stance begins.
  t += 0.001;
  s = internalState(pipeline, t);
  s.joint_position[lift] -= (footZ(s) - r.contactOffset()) / slope;
  pipeline.tick(s, out);
  EXPECT_EQ(pipeline.lastTick().late_feet >> kFoot & 1, 0);
  EXPECT_EQ(pipeline.lastTick().mode >> kFoot & 1, 1);
}

// The reference leash (mpc.reference_leash): a robot held where it started while the
// command asks for 0.5 m/s. The MPC moves its base reference to stay 0.05 m ahead of the
// measured base, and the real-time side adopts the same correction with each solution (its
// foothold regions follow the reference the plan was solved on); with the leash off both
// references run away from the robot.
// Deflection compensation (integrator.deflection_compensation): standing on flat, the
// position servos' compliance holds the body below the internal state's height (1.7 mm
// here, after the integrator's default blend of the measured state took its share; knees
// of 60 kN/m under a sixth of the weight each); with the compensation the measured body
// stays within a quarter of that (0.36 mm), and the tick still allocates nothing. (With
// the faster blend of 0.1 s / 0.02 s: 1.2 mm and 0.1 mm.)
TEST(NmpcController, DeflectionCompensationHoldsTheBodyAtTheInternalHeight) {
  const auto sag = [](double compensation, std::size_t& allocations) {
    SceneConfig scene;
    Plant plant(scene);
    const centroidal::RobotOcpDescription robot =
        centroidal::loadRobotOcpDescription(tachyon3Description());
    control::ControlSettings settings = shortHorizon();
    settings.integrator.deflection_compensation = compensation;
    NmpcController controller(plant, robot, settings, terrainFromScene(scene, 0.085),
                              planning::GaitKind::Standing, planning::BaseVelocityCommand{});
    runTicks(controller, plant, 1000);  // settled
    double sum = 0.0;
    const int n = 200;
    PlantCommand command = plant.command();
    allocations = 0;
    for (int k = 0; k < n; ++k) {
      {
        rollstep::test::AllocationGuard guard;
        controller.compute(plant.time(), plant.sensors(), command);
        allocations += guard.count();
      }
      plant.setCommand(command);
      plant.step();
      sum += controller.pipeline().integrator().q()[2] - plant.groundTruth().base_position.z();
    }
    return sum / n;
  };
  std::size_t allocations_off = 0, allocations_on = 0;
  const double off = sag(0.0, allocations_off);
  const double on = sag(1.0, allocations_on);
  std::printf(
      "stand: internal minus measured base height %.2f mm without, %.2f mm with "
      "deflection compensation\n",
      1e3 * off, 1e3 * on);
  EXPECT_GT(off, 0.0008);
  EXPECT_LT(std::abs(on), 0.25 * off);
  EXPECT_EQ(allocations_on, allocations_off);

  // Asked for without the servos' stiffness in the robot description: a clear error.
  SceneConfig scene;
  Plant plant(scene);
  centroidal::RobotOcpDescription robot =
      centroidal::loadRobotOcpDescription(tachyon3Description());
  robot.servo_stiffness.resize(0);
  control::ControlSettings settings = shortHorizon();
  settings.integrator.deflection_compensation = 1.0;
  EXPECT_THROW(NmpcController(plant, robot, settings, terrainFromScene(scene, 0.085),
                              planning::GaitKind::Standing, planning::BaseVelocityCommand{}),
               std::invalid_argument);
}

TEST(NmpcController, ReferenceLeashReachesTheRealTimeSide) {
  for (const double leash : {0.0, 0.05}) {
    SceneConfig scene;
    Plant plant(scene);
    const centroidal::RobotOcpDescription robot =
        centroidal::loadRobotOcpDescription(tachyon3Description());
    control::ControlSettings settings = shortHorizon();
    settings.mpc.reference_leash = leash;
    settings.ocp.speed_adaptation = false;  // the command at once, not ramped from rest
    NmpcController controller(plant, robot, settings, terrainFromScene(scene, 0.085),
                              planning::GaitKind::Standing,
                              planning::BaseVelocityCommand{0.5, 0, 0});
    control::ControlPipeline& pipeline = controller.pipeline();
    control::JointCommand out = pipeline.makeCommand();
    control::RobotState s = internalState(pipeline, plant.time());
    const control::RobotState held = s;
    for (int k = 0; k < 300; ++k) {
      s = held;  // the measured robot stays where it started
      s.time = plant.time() + 0.001 * (k + 1);
      pipeline.tick(s, out);
    }
    const double t = s.time;
    const lie::SE3 rt = pipeline.contactPlanner().baseReference().correction();
    const double ahead = pipeline.contactPlanner().baseReference().poseAt(t).translation.x() -
                         held.base_position.x();
    if (leash == 0.0) {
      EXPECT_TRUE(rt.translation.isZero(0.0));
      EXPECT_NEAR(ahead, 0.5 * (t - plant.time()), 1e-9);
    } else {
      // The last adopted solution was solved at most a period and its latency earlier:
      // the real-time side's reference is within 0.5 m/s x 0.03 s of the leash.
      EXPECT_LT(rt.translation.x(), -0.05);
      EXPECT_NEAR(ahead, 0.05, 0.5 * 0.03 + 1e-9);
    }
    EXPECT_EQ(pipeline.counters().invalid_states, 0u);
    EXPECT_TRUE(out.joint_position.allFinite());
  }
}

// A new terrain (perception's hand-over, ControlPipeline::setTerrain): the MPC solves on it
// from its next solve, the real-time side changes to it with the first solution solved on
// it, and neither allocates (the terrains are swapped in); a terrain the problem cannot take
// is refused and the one in use stays.
TEST(NmpcController, TerrainHandOverIsAllocationFreeAndRefusesUnfitTerrains) {
  SceneConfig scene;
  Plant plant(scene);
  const centroidal::RobotOcpDescription robot =
      centroidal::loadRobotOcpDescription(tachyon3Description());
  control::ControlSettings settings = shortHorizon();
  NmpcController controller(plant, robot, settings, terrainFromScene(scene, 0.085),
                            planning::GaitKind::Trot, planning::BaseVelocityCommand{0.1, 0, 0},
                            StateSourceOptions{}, 6);
  runTicks(controller, plant, 30);
  control::ControlPipeline& pipeline = controller.pipeline();
  control::JointCommand out = pipeline.makeCommand();
  control::RobotState s = internalState(pipeline, plant.time());
  // The floor in two pieces, one a hexagon (6 edges, the capacity), 1 mm higher.
  const planning::TerrainModel before = pipeline.contactPlanner().terrain();
  const planning::TerrainModel next({
      planning::ConvexRegion::fromPolygon({{-3, -1}, {0.2, -1}, {0.2, 1}, {-3, 1}}, 0.001),
      planning::ConvexRegion::fromPolygon(
          {{0.2, -1}, {3, -1}, {3.2, -0.5}, {3.2, 0.5}, {3, 1}, {0.2, 1}}, 0.001),
  });
  const std::uint64_t version = pipeline.setTerrain(next);
  EXPECT_EQ(version, 1u);
  // Refused: empty, or a region with more edges than the capacity.
  EXPECT_EQ(pipeline.setTerrain(planning::TerrainModel()), 0u);
  std::vector<Eigen::Vector2d> octagon;
  for (int k = 0; k < 8; ++k) {
    octagon.emplace_back(std::cos(k * M_PI / 4), std::sin(k * M_PI / 4));
  }
  EXPECT_EQ(pipeline.setTerrain(
                planning::TerrainModel({planning::ConvexRegion::fromPolygon(octagon, 0.0)})),
            0u);
  std::size_t count = 0;
  std::uint64_t version_seen_by_rt = 0;
  for (int k = 0; k < 60; ++k) {
    s.time += 0.001;
    rollstep::test::AllocationGuard guard;
    pipeline.tick(s, out);
    count += guard.count();
    if (version_seen_by_rt == 0 && pipeline.terrainVersion() == version) {
      // The real-time side changed with the solution solved on it, not before.
      EXPECT_TRUE(pipeline.lastTick().solution_adopted);
      EXPECT_EQ(pipeline.lastSolution().terrain_version, version);
      version_seen_by_rt = version;
    }
  }
  EXPECT_EQ(count, 0u) << "the real-time tick allocated around a terrain hand-over";
  EXPECT_EQ(version_seen_by_rt, version);
  EXPECT_EQ(pipeline.counters().terrain_updates, 1u);
  EXPECT_EQ(pipeline.runner().terrainVersion(), version);
  const planning::TerrainModel& now = pipeline.contactPlanner().terrain();
  ASSERT_EQ(now.size(), 2);
  EXPECT_EQ(now.region(1).vertices.size(), 6u);
  EXPECT_DOUBLE_EQ(now.heightAt({1.0, 0.0}), 0.001);
  EXPECT_NE(before.size(), 2);  // it really changed
  EXPECT_TRUE(out.joint_position.allFinite());
}

// The hand-over across threads (asynchronous MPC: its own thread swaps the terrain in at the
// start of a solve while this thread publishes the next ones and ticks): every terrain
// published reaches both sides, the newest in the end (the sanitizer trees run this too:
// ThreadSanitizer checks the exchange).
TEST(NmpcController, TerrainHandOverReachesAnAsynchronousMpc) {
  SceneConfig scene;
  Plant plant(scene);
  const centroidal::RobotOcpDescription robot =
      centroidal::loadRobotOcpDescription(tachyon3Description());
  const control::ControlSettings settings = asynchronousMpc();
  NmpcController controller(plant, robot, settings, terrainFromScene(scene, 0.085),
                            planning::GaitKind::Standing, planning::BaseVelocityCommand{},
                            StateSourceOptions{}, 4);
  control::ControlPipeline& pipeline = controller.pipeline();
  control::JointCommand out = pipeline.makeCommand();
  control::RobotState s = internalState(pipeline, plant.time());
  const auto floorAt = [](double h) {
    return planning::TerrainModel(
        {planning::ConvexRegion::fromPolygon({{-3, -2}, {3, -2}, {3, 2}, {-3, 2}}, h)});
  };
  std::uint64_t last = 0;
  for (int k = 0; k < 5; ++k) {
    last = pipeline.setTerrain(floorAt(0.001 * (k + 1)));
    ASSERT_EQ(last, static_cast<std::uint64_t>(k + 1));
    for (int j = 0; j < 20; ++j) {
      s.time += 0.001;
      pipeline.tick(s, out);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  // Wait (wall clock) until the MPC solved on the last one and this side adopted it. This
  // side adopts the newest published terrain with the first solution solved on a newer one
  // than its own, so it can reach the last version one solve before the MPC takes it (a
  // terrain published between a solve's start and its solution's arrival): wait for both.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while ((pipeline.terrainVersion() != last || pipeline.runner().terrainVersion() != last) &&
         std::chrono::steady_clock::now() < deadline) {
    s.time += 0.001;
    pipeline.tick(s, out);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  pipeline.stop();
  EXPECT_EQ(pipeline.runner().terrainVersion(), last);
  EXPECT_EQ(pipeline.terrainVersion(), last);
  EXPECT_DOUBLE_EQ(pipeline.contactPlanner().terrain().heightAt({0.0, 0.0}), 0.005);
  EXPECT_GE(pipeline.counters().terrain_updates, 1u);
  EXPECT_TRUE(out.joint_position.allFinite());
}

// Asynchronous MPC and asynchronous perception together (three threads: this one ticks and
// posts the scans, the perception thread builds terrains and hands them to the pipeline, the
// MPC thread solves on them): this thread allocates nothing, every scan is accounted for,
// and the real-time side ends on a terrain the perception thread built.
TEST(NmpcController, AsynchronousPerceptionFeedsAnAsynchronousMpc) {
  SceneConfig scene;
  Plant plant(scene);
  const centroidal::RobotOcpDescription robot =
      centroidal::loadRobotOcpDescription(tachyon3Description());
  const control::ControlSettings settings = asynchronousMpc();
  OnlinePerceptionOptions options;
  options.asynchronous = true;
  auto perception = std::make_unique<OnlinePerception>(options);
  perception->start(plant, plant.groundTruth().base_position, plant.groundTruth().base_orientation);
  const double margin = centroidal::footholdRegionMargin(robot, settings.ocp);
  NmpcController controller(plant, robot, settings, perception->footholdTerrain(margin),
                            planning::GaitKind::Standing, planning::BaseVelocityCommand{},
                            StateSourceOptions{}, options.perception.regions.directions);
  controller.setPerception(std::move(perception), margin);
  controller.enableTerrainLog();  // written by the perception thread, read after stop()
  OnlinePerception& p = *controller.perception();
  ASSERT_TRUE(p.asynchronous());
  PlantCommand command = plant.command();
  std::size_t count = 0;
  for (int k = 0; k < 600; ++k) {  // 0.6 s: scans at 0.1, ..., 0.5 s
    {
      rollstep::test::AllocationGuard guard;
      controller.compute(plant.time(), plant.sensors(), command);
      count += guard.count();
    }
    plant.setCommand(command);
    plant.step();
    std::this_thread::sleep_for(std::chrono::microseconds(500));  // let the threads run
  }
  EXPECT_EQ(count, 0u) << "the simulation thread allocated";
  p.stop();
  const OnlinePerceptionCounters& c = p.counters();
  EXPECT_EQ(c.scans, 5u);
  EXPECT_EQ(c.terrains - 1 + c.kept + c.superseded, c.scans);  // 1: start()'s
  EXPECT_GE(c.handed_over, 1u);
  EXPECT_EQ(c.handed_over, c.terrains - 1);
  EXPECT_EQ(c.refused, 0u);
  // The MPC solves on the newest terrain handed over and the tick adopts it (wall clock).
  // Wait for both: the tick can adopt the newest published terrain one solve before the
  // MPC records it as its own (session 13's note; a slow ASan run showed 5 against 4).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while ((controller.pipeline().terrainVersion() < c.handed_over ||
          controller.pipeline().runner().terrainVersion() < c.handed_over) &&
         std::chrono::steady_clock::now() < deadline) {
    controller.compute(plant.time(), plant.sensors(), command);
    plant.setCommand(command);
    plant.step();
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  controller.pipeline().stop();
  EXPECT_EQ(controller.pipeline().runner().terrainVersion(), c.handed_over);
  EXPECT_EQ(controller.pipeline().terrainVersion(), c.handed_over);
  // terrains.csv: version 0 (the constructor's) and every version handed over, in order,
  // each with its regions' vertices.
  const std::string csv = controller.terrainsCsv();
  ASSERT_EQ(csv.rfind("version[-],region[-],vertex[-],x[m],y[m],z[m]\n", 0), 0u);
  std::vector<unsigned long> versions;
  for (std::size_t at = csv.find('\n') + 1; at < csv.size(); at = csv.find('\n', at) + 1) {
    const unsigned long v = std::stoul(csv.substr(at, csv.find(',', at) - at));
    if (versions.empty() || versions.back() != v) versions.push_back(v);
  }
  std::vector<unsigned long> expected;
  for (unsigned long v = 0; v <= c.handed_over; ++v) expected.push_back(v);
  EXPECT_EQ(versions, expected);
  EXPECT_LT(plant.groundTruth().base_orientation.angularDistance(Eigen::Quaterniond::Identity()),
            0.05);
}

}  // namespace
}  // namespace rollstep::sim::test
