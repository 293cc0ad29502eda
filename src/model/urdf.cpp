// URDF loading (urdfdom) into a Model: fixed joints merged, bodies in depth-first order.
#include <console_bridge/console.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "rollstep/model/model.hpp"

namespace rollstep::model {

namespace {

// Collects urdfdom's error messages (it reports them through console_bridge).
class CaptureHandler : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char* /*filename*/,
           int /*line*/) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_WARN) {
      if (!messages.empty()) messages += "; ";
      messages += text;
    }
  }
  std::string messages;
};

Eigen::Matrix3d toRotation(const urdf::Rotation& r) {
  return Eigen::Quaterniond(r.w, r.x, r.y, r.z).normalized().toRotationMatrix();
}
Eigen::Vector3d toVector(const urdf::Vector3& v) { return Eigen::Vector3d(v.x, v.y, v.z); }

struct BodyAccumulator {
  double mass = 0.0;
  Eigen::Vector3d firstMoment = Eigen::Vector3d::Zero();    // body frame
  Eigen::Matrix3d inertiaOrigin = Eigen::Matrix3d::Zero();  // about body origin, body axes
};

void checkInertial(const urdf::Link& link) {
  if (!link.inertial) return;
  const urdf::Inertial& in = *link.inertial;
  if (!(in.mass > 0.0) || !std::isfinite(in.mass)) {
    std::ostringstream os;
    os << "link '" << link.name << "': mass " << in.mass << " is not positive";
    throw ModelError(os.str());
  }
  Eigen::Matrix3d I;
  I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(I, Eigen::EigenvaluesOnly);
  if (!I.allFinite() || !(es.eigenvalues().minCoeff() > 0.0)) {
    std::ostringstream os;
    os << "link '" << link.name << "': inertia tensor is not positive definite (eigenvalues "
       << es.eigenvalues().transpose() << ")";
    throw ModelError(os.str());
  }
}

void addInertia(BodyAccumulator& acc, const urdf::Link& link, const Eigen::Matrix3d& R_bl,
                const Eigen::Vector3d& p_bl) {
  if (!link.inertial) return;
  const urdf::Inertial& in = *link.inertial;
  Eigen::Matrix3d I;
  I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  const Eigen::Matrix3d R = R_bl * toRotation(in.origin.rotation);
  const Eigen::Vector3d c = p_bl + R_bl * toVector(in.origin.position);
  acc.mass += in.mass;
  acc.firstMoment += in.mass * c;
  acc.inertiaOrigin +=
      R * I * R.transpose() +
      in.mass * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
}

class Builder {
 public:
  Builder(const urdf::ModelInterface& urdf, RootJoint root) : urdf_(urdf) {
    model_.name = urdf.getName();
    model_.root = root;
    model_.nqBase = root == RootJoint::FreeFlyer ? 7 : 0;
    model_.nvBase = root == RootJoint::FreeFlyer ? 6 : 0;
  }

  Model build() {
    const urdf::LinkConstSharedPtr root = urdf_.getRoot();
    if (!root) throw ModelError("URDF '" + urdf_.getName() + "' has no root link");
    checkTopology(*root);
    Body b;
    b.name = root->name;
    model_.bodies.push_back(b);
    acc_.emplace_back();
    visit(*root, 0, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
    finish();
    return model_;
  }

 private:
  // Every link reached exactly once from the root; unsupported joint types rejected.
  void checkTopology(const urdf::Link& root) {
    std::map<std::string, std::string> parentJoint;  // child link -> joint
    for (const auto& [name, joint] : urdf_.joints_) {
      switch (joint->type) {
        case urdf::Joint::REVOLUTE:
        case urdf::Joint::CONTINUOUS:
        case urdf::Joint::PRISMATIC:
        case urdf::Joint::FIXED:
          break;
        case urdf::Joint::FLOATING:
          throw ModelError("joint '" + name + "': unsupported joint type 'floating'");
        case urdf::Joint::PLANAR:
          throw ModelError("joint '" + name + "': unsupported joint type 'planar'");
        default:
          throw ModelError("joint '" + name + "': unknown joint type");
      }
      auto [it, inserted] = parentJoint.emplace(joint->child_link_name, name);
      if (!inserted) {
        throw ModelError("link '" + joint->child_link_name + "' is the child of two joints ('" +
                         it->second + "' and '" + name + "'): kinematic loops are not supported");
      }
      if (joint->type != urdf::Joint::FIXED) {
        const Eigen::Vector3d a = toVector(joint->axis);
        if (!(a.norm() > 1e-12)) throw ModelError("joint '" + name + "': zero axis");
      }
    }
    if (parentJoint.count(root.name) != 0) {
      throw ModelError("root link '" + root.name + "' has a parent joint (kinematic loop)");
    }
    std::set<std::string> reached;
    std::vector<const urdf::Link*> stack{&root};
    while (!stack.empty()) {
      const urdf::Link* l = stack.back();
      stack.pop_back();
      if (!reached.insert(l->name).second) {
        throw ModelError("link '" + l->name + "' is reached twice from the root (kinematic loop)");
      }
      checkInertial(*l);
      for (const auto& c : l->child_links) stack.push_back(c.get());
    }
    for (const auto& [name, link] : urdf_.links_) {
      if (reached.count(name) == 0) {
        throw ModelError("link '" + name + "' is not connected to the root link '" + root.name +
                         "' (kinematic loop or several roots)");
      }
    }
  }

  // Depth-first: link `link` belongs to body `body` with placement (R_bl, p_bl) in it.
  void visit(const urdf::Link& link, int body, const Eigen::Matrix3d& R_bl,
             const Eigen::Vector3d& p_bl) {
    Frame f;
    f.name = link.name;
    f.body = body;
    f.rotation = R_bl;
    f.translation = p_bl;
    model_.frames.push_back(f);
    addInertia(acc_[static_cast<std::size_t>(body)], link, R_bl, p_bl);

    for (std::size_t c = 0; c < link.child_joints.size(); ++c) {
      const urdf::Joint& joint = *link.child_joints[c];
      const urdf::Link& child = *link.child_links[c];
      const Eigen::Matrix3d R_j =
          R_bl * toRotation(joint.parent_to_joint_origin_transform.rotation);
      const Eigen::Vector3d p_j =
          p_bl + R_bl * toVector(joint.parent_to_joint_origin_transform.position);
      if (joint.type == urdf::Joint::FIXED) {
        visit(child, body, R_j, p_j);
        continue;
      }
      Body b;
      b.name = child.name;
      b.parent = body;
      b.joint = joint.name;
      b.type = joint.type == urdf::Joint::PRISMATIC ? JointType::Prismatic : JointType::Revolute;
      b.axis = toVector(joint.axis).normalized();
      b.jointRotation = R_j;
      b.jointTranslation = p_j;
      b.axisHat = lie::hat(b.axis);
      b.axisHat2 = b.axisHat * b.axisHat;
      const int j = model_.nj++;
      b.idxQ = model_.nqBase + j;
      b.idxV = model_.nvBase + j;
      model_.jointNames.push_back(joint.name);
      double lower = -std::numeric_limits<double>::infinity();
      double upper = std::numeric_limits<double>::infinity();
      double vel = std::numeric_limits<double>::infinity();
      double eff = std::numeric_limits<double>::infinity();
      if (joint.limits) {
        if (joint.type != urdf::Joint::CONTINUOUS) {
          lower = joint.limits->lower;
          upper = joint.limits->upper;
        }
        if (joint.limits->velocity > 0) vel = joint.limits->velocity;
        if (joint.limits->effort > 0) eff = joint.limits->effort;
      }
      limits_.push_back({lower, upper, vel, eff});
      const int id = model_.nbodies();
      model_.bodies.push_back(b);
      acc_.emplace_back();
      visit(child, id, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
    }
  }

  void finish() {
    Model& m = model_;
    m.nq = m.nqBase + m.nj;
    m.nv = m.nvBase + m.nj;
    m.lowerPositionLimit.resize(m.nj);
    m.upperPositionLimit.resize(m.nj);
    m.velocityLimit.resize(m.nj);
    m.effortLimit.resize(m.nj);
    for (int j = 0; j < m.nj; ++j) {
      const auto& l = limits_[static_cast<std::size_t>(j)];
      m.lowerPositionLimit[j] = l[0];
      m.upperPositionLimit[j] = l[1];
      m.velocityLimit[j] = l[2];
      m.effortLimit[j] = l[3];
    }
    const int nb = m.nbodies();
    for (int i = 0; i < nb; ++i) {
      Body& b = m.bodies[static_cast<std::size_t>(i)];
      const BodyAccumulator& a = acc_[static_cast<std::size_t>(i)];
      b.mass = a.mass;
      if (a.mass > 0.0) {
        b.com = a.firstMoment / a.mass;
        b.inertia = a.inertiaOrigin - a.mass * (b.com.squaredNorm() * Eigen::Matrix3d::Identity() -
                                                b.com * b.com.transpose());
      }
      b.subtreeEnd = i + 1;
      b.subtreeMass = b.mass;
    }
    for (int i = nb - 1; i > 0; --i) {
      Body& b = m.bodies[static_cast<std::size_t>(i)];
      Body& p = m.bodies[static_cast<std::size_t>(b.parent)];
      p.subtreeMass += b.subtreeMass;
      p.subtreeEnd = std::max(p.subtreeEnd, b.subtreeEnd);
    }
    m.totalMass = m.bodies[0].subtreeMass;
    if (!(m.totalMass > 0.0)) throw ModelError("URDF '" + m.name + "' has zero total mass");
  }

  const urdf::ModelInterface& urdf_;
  Model model_;
  std::vector<BodyAccumulator> acc_;
  std::vector<std::array<double, 4>> limits_;
};

}  // namespace

Model buildModelFromUrdfString(const std::string& xml, RootJoint root) {
  CaptureHandler handler;
  console_bridge::useOutputHandler(&handler);
  urdf::ModelInterfaceSharedPtr urdf;
  try {
    urdf = urdf::parseURDF(xml);
  } catch (...) {
    console_bridge::restorePreviousOutputHandler();
    throw;
  }
  console_bridge::restorePreviousOutputHandler();
  if (!urdf) {
    throw ModelError("URDF rejected by urdfdom: " +
                     (handler.messages.empty() ? std::string("parse error") : handler.messages));
  }
  // urdfdom links hold shared pointers to their children: a kinematic loop would leak the
  // whole tree. Break every link's references when leaving (success or error).
  struct TreeReleaser {
    urdf::ModelInterface& m;
    ~TreeReleaser() {
      for (auto& [name, link] : m.links_) {
        link->child_links.clear();
        link->child_joints.clear();
        link->parent_joint.reset();
      }
    }
  } releaser{*urdf};
  return Builder(*urdf, root).build();
}

Model buildModelFromUrdfFile(const std::string& path, RootJoint root) {
  std::ifstream in(path);
  if (!in) throw ModelError("cannot open URDF file '" + path + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  try {
    return buildModelFromUrdfString(ss.str(), root);
  } catch (const ModelError& e) {
    throw ModelError(path + ": " + e.what());
  }
}

}  // namespace rollstep::model
