#pragma once
// The tracking stage both 1 kHz pipelines end their tick with (ControlPipeline: the refined
// MPC solution as reference; BaselinePipeline: the reactive plan): the feet of the internal
// state, the acceleration targets (each pipeline writes its own feedback law into
// targets(), from configurationError() and the feet), the CBF-QP safety filter, the
// internal state integrator (measured state blended in) and the joint commands. Also what
// a tick reports: the command, the tick's record and the run's counters.
//
// Real-time contract: everything but construction never allocates, locks or throws.
#include <Eigen/Core>
#include <cstdint>
#include <memory>

#include "rollstep/centroidal/robot.hpp"
#include "rollstep/control/cbf_qp.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/control/state_integrator.hpp"
#include "rollstep/model/data.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::control {

/// What the pipeline sends to the actuators.
struct JointCommand {
  Eigen::VectorXd joint_position;  ///< nj, model joint order [rad or m]
  Eigen::VectorXd joint_velocity;  ///< nj, the internal state's joint velocities
  Eigen::VectorXd wheel_velocity;  ///< one per drive wheel, in contact order [rad/s]
};

/// What happened in one tick (for logs and tests).
struct TickRecord {
  double time = 0.0;
  int mode = 0;             ///< contact mask of the contact planner at t
  int late_feet = 0;        ///< feet whose stance is delayed until they land (landLateFeet), a mask
  bool state_valid = true;  ///< false: the state was rejected, the command kept
  bool new_solution = false;            ///< a solution arrived this tick
  bool solution_adopted = false;        ///< ... and was refined into the reference
  std::uint64_t solution_sequence = 0;  ///< of the reference in use
  CbfQpStatus cbf_status = CbfQpStatus::Optimal;
  DenseQpStatus qp_status = DenseQpStatus::Optimal;
  int qp_iterations = 0;
  int active_barriers = 0;
  std::uint64_t active_foot_barriers = 0;  ///< CbfQpFilter::activeFootBarriers()
  int active_joint_limits = 0;             ///< CbfQpFilter::activeJointLimits()
  int active_support_edges = 0;            ///< CbfQpFilter::activeSupportEdges()
  double correction = 0.0;                 ///< CbfQpFilter::correction()
  bool holding = false;                    ///< stale-solution watchdog: holding the safe posture
  std::uint64_t terrain_version = 0;       ///< of the real-time side's terrain (0: the initial)
};

/// Counters over the run.
struct PipelineCounters {
  std::uint64_t ticks = 0;
  std::uint64_t invalid_states = 0;
  std::uint64_t solutions_received = 0;
  std::uint64_t solutions_rejected = 0;    ///< unusable, reference kept
  std::uint64_t qp_fallbacks = 0;          ///< ticks on the CBF-QP's brake fallback
  std::uint64_t qp_relaxations = 0;        ///< ticks on its relaxed barriers (CbfQpStatus::Relaxed)
  std::uint64_t watchdog_trips = 0;        ///< solution older than mpc.max_solution_age: hold began
  std::uint64_t holding_ticks = 0;         ///< ticks spent holding the safe posture
  std::uint64_t stale_solutions = 0;       ///< older than mpc.max_solution_age on arrival: ignored
  std::uint64_t terrain_updates = 0;       ///< new terrains the real-time side changed to
  std::uint64_t late_touchdown_ticks = 0;  ///< ticks with a foot landing late (any foot)
};

class TrackingStage {
 public:
  /// The filter on `terrain` (and `collision_terrain`, CbfQpFilter's arguments; both are
  /// referenced, not copied) with settings.cbf_qp, the integrator with settings.integrator
  /// at settings.control_period. Throws std::invalid_argument for bad settings.
  TrackingStage(std::shared_ptr<const centroidal::CentroidalRobot> robot,
                const planning::TerrainModel& terrain, const ControlSettings& settings,
                double lateral_slip_weight,
                const planning::TerrainModel* collision_terrain = nullptr,
                int collision_prism_capacity = 0);

  /// The internal state starts at (q, v).
  void reset(const Eigen::VectorXd& q, const Eigen::VectorXd& v) noexcept;

  /// The contact frames' origins of the internal state (world) and their velocities
  /// (LOCAL_WORLD_ALIGNED) into footPositions(), footVelocities().
  void updateFeet() noexcept;
  /// q_ref (-) the internal state's q, in its tangent (LOCAL), nv.
  const Eigen::VectorXd& configurationError(const Eigen::VectorXd& q_ref) noexcept;
  /// The targets the filter takes, sized for the robot: the owner's feedback law writes them.
  AccelerationTargets& targets() { return targets_; }

  /// Filters targets() at the internal state in contact mask `mode` with the feet's
  /// `regions` (nc entries, or null); records the outcome (status, QP status and
  /// iterations, active barriers, correction) in `record` and counts a relaxation or a
  /// fallback in `counters`. Returns true on the fallback (neither Optimal nor Relaxed).
  bool filter(int mode, const FootRegionPlan* regions, TickRecord& record,
              PipelineCounters& counters) noexcept;
  /// The filtered acceleration (nv; the owner may override a fallback's before step()).
  Eigen::VectorXd& acceleration() { return a_; }
  /// Integrates acceleration() with the measurement blended in; the joints are commanded to
  /// the new internal state (command.joint_position, joint_velocity).
  void step(const Eigen::VectorXd& q_measured, const Eigen::VectorXd& v_measured,
            JointCommand& command) noexcept;

  const Eigen::VectorXd& q() const { return integrator_.q(); }
  const Eigen::VectorXd& v() const { return integrator_.v(); }
  const Eigen::Matrix3Xd& footPositions() const { return foot_p_; }
  const Eigen::Matrix3Xd& footVelocities() const { return foot_v_; }
  const StateIntegrator& integrator() const { return integrator_; }
  const CbfQpFilter& safetyFilter() const { return filter_; }
  CbfQpFilter& safetyFilter() { return filter_; }

 private:
  std::shared_ptr<const centroidal::CentroidalRobot> robot_;
  CbfQpFilter filter_;
  StateIntegrator integrator_;
  model::Data data_;
  AccelerationTargets targets_;
  Eigen::VectorXd a_, dq_;
  Eigen::Matrix3Xd foot_p_, foot_v_;
};

}  // namespace rollstep::control
