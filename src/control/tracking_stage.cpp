// The tracking stage of both pipelines (tracking_stage.hpp).
#include "rollstep/control/tracking_stage.hpp"

#include <utility>

#include "rollstep/model/kinematics.hpp"

namespace rollstep::control {

TrackingStage::TrackingStage(std::shared_ptr<const centroidal::CentroidalRobot> robot,
                             const planning::TerrainModel& terrain, const ControlSettings& settings,
                             double lateral_slip_weight,
                             const planning::TerrainModel* collision_terrain,
                             int collision_prism_capacity)
    : robot_(std::move(robot)),
      filter_(robot_, terrain, settings.cbf_qp, lateral_slip_weight, collision_terrain,
              collision_prism_capacity),
      integrator_(robot_->modelPtr(), settings.integrator, settings.control_period),
      data_(robot_->model()),
      targets_(filter_.makeTargets()),
      a_(Eigen::VectorXd::Zero(robot_->nv())),
      dq_(Eigen::VectorXd::Zero(robot_->nv())),
      foot_p_(Eigen::Matrix3Xd::Zero(3, robot_->nc())),
      foot_v_(Eigen::Matrix3Xd::Zero(3, robot_->nc())) {}

void TrackingStage::reset(const Eigen::VectorXd& q, const Eigen::VectorXd& v) noexcept {
  integrator_.reset(q, v);
}

void TrackingStage::updateFeet() noexcept {
  const centroidal::CentroidalRobot& r = *robot_;
  const model::Model& m = r.model();
  model::forwardKinematics(m, data_, integrator_.q(), integrator_.v());
  for (int i = 0; i < r.nc(); ++i) {
    const model::FrameIndex f = r.frameIds()[static_cast<size_t>(i)];
    model::updateFramePlacement(m, data_, f);
    foot_p_.col(i) = data_.opf[static_cast<size_t>(f)];
    foot_v_.col(i) =
        model::getFrameVelocity(m, data_, f, model::ReferenceFrame::LOCAL_WORLD_ALIGNED).head<3>();
  }
}

const Eigen::VectorXd& TrackingStage::configurationError(const Eigen::VectorXd& q_ref) noexcept {
  model::difference(robot_->model(), integrator_.q(), q_ref, dq_);
  return dq_;
}

bool TrackingStage::filter(int mode, const FootRegionPlan* regions, TickRecord& record,
                           PipelineCounters& counters) noexcept {
  const CbfQpStatus status =
      filter_.filter(integrator_.q(), integrator_.v(), mode, regions, targets_, a_);
  record.cbf_status = status;
  record.qp_status = filter_.qpStatus();
  record.qp_iterations = filter_.qpIterations();
  record.active_barriers = filter_.activeBarriers();
  record.active_foot_barriers = filter_.activeFootBarriers();
  record.active_joint_limits = filter_.activeJointLimits();
  record.active_support_edges = filter_.activeSupportEdges();
  record.correction = filter_.correction();
  if (status == CbfQpStatus::Relaxed) ++counters.qp_relaxations;
  const bool fallback = status != CbfQpStatus::Optimal && status != CbfQpStatus::Relaxed;
  if (fallback) ++counters.qp_fallbacks;
  return fallback;
}

void TrackingStage::step(const Eigen::VectorXd& q_measured, const Eigen::VectorXd& v_measured,
                         JointCommand& command) noexcept {
  integrator_.step(a_, q_measured, v_measured);
  const int nj = robot_->nj();
  command.joint_position = integrator_.q().tail(nj);
  command.joint_velocity = integrator_.v().tail(nj);
}

}  // namespace rollstep::control
