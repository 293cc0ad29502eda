#include "rollstep/centroidal/loaded_robot.hpp"

#include <limits>
#include <sstream>
#include <stdexcept>

#include "rollstep/centroidal/precomputation.hpp"
#include "rollstep/model/kinematics.hpp"

namespace rollstep::centroidal {

namespace {

int indexOf(const std::vector<std::string>& names, const std::string& name) {
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return static_cast<int>(i);
  }
  throw std::invalid_argument("'" + name + "' is not a contact frame");
}

/// The groups `gait` needs, from the description (the others stay empty).
planning::GaitGroups gaitGroups(const RobotOcpDescription& d, planning::GaitKind gait) {
  planning::GaitGroups groups;
  if (gait == planning::GaitKind::Trot) {
    if (d.trot_group_a.empty() || d.trot_group_b.empty()) {
      throw std::invalid_argument("the robot description gives no trot_groups: cannot trot");
    }
    groups.trot_a = planning::contactMask(d.contact_frames, d.trot_group_a);
    groups.trot_b = planning::contactMask(d.contact_frames, d.trot_group_b);
  } else if (gait == planning::GaitKind::StaticWalk) {
    if (d.walk_order.empty()) {
      throw std::invalid_argument("the robot description gives no walk_order: cannot walk");
    }
    for (const std::string& name : d.walk_order) {
      groups.walk_order.push_back(indexOf(d.contact_frames, name));
    }
  }
  return groups;
}

}  // namespace

LoadedRobot loadRobot(const RobotOcpDescription& description) {
  LoadedRobot out;
  out.description = description;
  auto model =
      std::make_shared<const model::Model>(model::buildModelFromUrdfFile(description.urdf));
  std::vector<ContactDescription> contacts;
  for (const std::string& frame : description.contact_frames) {
    bool drive = false;
    for (const std::string& w : description.drive_wheels) drive = drive || w == frame;
    contacts.push_back({frame, drive});
  }
  std::vector<std::array<int, 2>> pairs;
  for (const auto& p : description.side_pairs) {
    pairs.push_back(
        {indexOf(description.contact_frames, p[0]), indexOf(description.contact_frames, p[1])});
  }
  out.robot =
      std::make_shared<const CentroidalRobot>(model, contacts, pairs, description.contact_offset);
  const CentroidalRobot& robot = *out.robot;
  const int nj = robot.nj(), nc = robot.nc();
  const std::string description_name = description.source.empty()
                                           ? std::string("robot description: ")
                                           : "robot description " + description.source + ": ";
  const auto requireOnePerJoint = [&](const char* key, const Eigen::VectorXd& values) {
    if (values.size() != nj) {
      throw std::invalid_argument(description_name + std::string(key) + " has " +
                                  std::to_string(values.size()) + " entries, the URDF " +
                                  description.urdf + " has " + std::to_string(nj) + " joints");
    }
  };
  requireOnePerJoint("nominal_joint_positions", description.nominal_joint_positions);
  for (int j = 0; j < nj; ++j) {  // the posture every term pulls towards must be reachable
    const double q = description.nominal_joint_positions[j];
    const double lo = model->lowerPositionLimit[j], hi = model->upperPositionLimit[j];
    if (q < lo || q > hi) {
      std::ostringstream os;
      os << description_name << "nominal_joint_positions[" << j << "] = " << q << " for joint '"
         << model->jointNames[static_cast<std::size_t>(j)] << "' is outside its limits [" << lo
         << ", " << hi << "] in the URDF " << description.urdf;
      throw std::invalid_argument(os.str());
    }
  }
  if (description.servo_stiffness.size() != 0) {
    requireOnePerJoint("servo_stiffness", description.servo_stiffness);
  }

  // Nominal footholds and height, from the URDF at the nominal posture.
  const CentroidalPrecomputation pre(out.robot);
  CentroidalCache cache(robot);
  Eigen::VectorXd x(robot.nx());
  x << Eigen::Vector3d::Zero(), Eigen::Vector4d(0.0, 0.0, 0.0, 1.0),  // identity (x, y, z, w)
      description.nominal_joint_positions, Eigen::Matrix<double, 6, 1>::Zero();
  pre.compute(x, Eigen::VectorXd::Zero(robot.nu()), false, cache);
  double height = 0.0;
  for (int i = 0; i < nc; ++i) {
    const Eigen::Vector3d p = cache.footPosition(i);
    out.stance.feet.emplace_back(p.x(), p.y());
    height += -p.z() + robot.contactOffset();
  }
  out.stance.height = height / nc;
  out.stance.foot_height_offset = robot.contactOffset();
  return out;
}

planning::ContactPlannerSettings contactPlannerSettings(const OcpSettings& s) {
  planning::ContactPlannerSettings c;
  c.horizon = s.horizon * s.dt;
  c.gait.period = s.gait_period;
  c.gait.trot_duty = s.trot_duty;
  c.gait.walk_period = s.walk_period;
  c.gait.walk_duty = s.walk_duty;
  c.swing_clearance = s.swing_clearance;
  c.swing_apex_margin = s.swing_apex_margin;
  c.foothold_gap_reach = s.foothold_gap_reach;
  c.base_height_reach = s.base_height_reach;
  c.base_height_slope = s.base_height_slope;
  c.base_height_rate = s.base_height_rate;
  c.edge_holds.max_down_hold = s.step_down_max_hold;
  c.edge_holds.lead = s.edge_hold_lead;
  c.edge_holds.reach = s.step_down_reach;
  c.edge_holds.max_up_hold = s.step_up_max_hold;
  c.edge_holds.setback = s.step_up_setback;
  c.edge_holds.up_reach = s.step_up_reach;
  c.edge_holds.stance_stroke = s.edge_hold_stance_stroke;
  c.anchor_stance_feet = s.anchor_stance_feet;
  c.latch_touchdowns = s.latch_touchdowns;
  c.late_touchdown_tolerance = s.late_touchdown_tolerance;
  c.late_touchdown_max_delay = s.late_touchdown_max_delay;
  c.late_touchdown_speed = s.late_touchdown_speed;
  c.late_touchdown_min_time = 2.0 * s.dt;  // a landing spans at least two nodes
  return c;
}

std::unique_ptr<planning::ContactPlanner> makeContactPlanner(const LoadedRobot& robot,
                                                             const OcpSettings& settings,
                                                             planning::TerrainModel terrain,
                                                             planning::GaitKind gait,
                                                             int region_edge_capacity) {
  const planning::ContactPlannerSettings s = contactPlannerSettings(settings);
  planning::Gait made =
      planning::makeGait(gait, robot.robot->nc(), s.gait, gaitGroups(robot.description, gait));
  return std::make_unique<planning::ContactPlanner>(s, robot.stance, std::move(made),
                                                    std::move(terrain), region_edge_capacity);
}

bool contactPositionsOfState(const CentroidalRobot& robot, model::Data& data,
                             const Eigen::VectorXd& x, Eigen::Matrix3Xd& out) noexcept {
  if (x.size() != robot.nx() || !x.allFinite()) {
    out.setConstant(std::numeric_limits<double>::quiet_NaN());
    return false;
  }
  const model::Model& model = robot.model();
  model::forwardKinematics(model, data, x.head(robot.nq()));
  for (int i = 0; i < robot.nc(); ++i) {
    const model::FrameIndex f = robot.frameIds()[static_cast<std::size_t>(i)];
    model::updateFramePlacement(model, data, f);
    out.col(i) = data.opf[static_cast<std::size_t>(f)];
  }
  return true;
}

}  // namespace rollstep::centroidal
