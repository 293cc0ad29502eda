// URDF loading (urdfdom) into a Model: fixed joints merged, bodies in depth-first order.
#include <console_bridge/console.h>
#include <tinyxml.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <vector>

#include "rollstep/common/text_file.hpp"
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

/// The shortest text that reads back as v ("nan", "inf", "-1", "0.1", "1e+300").
std::string num(double v) {
  char buf[32];
  for (int digits = 6; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    if (!std::isfinite(v) || std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}
std::string vec(double x, double y, double z) {
  return "(" + num(x) + ", " + num(y) + ", " + num(z) + ")";
}

[[noreturn]] void fail(const std::string& element, const std::string& what) {
  throw ModelError(element + ": " + what);
}

/// Refuses XML whose elements nest deeper than kUrdfMaxXmlDepth. A conservative scan:
/// comments, CDATA, declarations and quoted attribute values are skipped; every start tag
/// that is not self-closing counts one level until its end tag.
void checkXmlNesting(const std::string& xml) {
  const std::size_t n = xml.size();
  int depth = 0;
  std::size_t i = 0;
  const auto skipPast = [&](const char* end) {
    const std::size_t at = xml.find(end, i);
    i = at == std::string::npos ? n : at + std::char_traits<char>::length(end);
  };
  while (i < n) {
    if (xml[i] != '<') {
      ++i;
      continue;
    }
    if (xml.compare(i, 4, "<!--") == 0) {
      skipPast("-->");
    } else if (xml.compare(i, 9, "<![CDATA[") == 0) {
      skipPast("]]>");
    } else if (xml.compare(i, 2, "<?") == 0 || xml.compare(i, 2, "<!") == 0) {
      skipPast(">");
    } else if (xml.compare(i, 2, "</") == 0) {
      if (depth > 0) --depth;
      skipPast(">");
    } else {
      // Start tag: find its end outside quotes.
      char quote = 0;
      std::size_t j = i + 1;
      for (; j < n; ++j) {
        const char c = xml[j];
        if (quote != 0) {
          if (c == quote) quote = 0;
        } else if (c == '"' || c == '\'') {
          quote = c;
        } else if (c == '>') {
          break;
        }
      }
      if (j >= n || xml[j - 1] != '/') {
        if (++depth > kUrdfMaxXmlDepth) {
          throw ModelError("URDF XML nests elements more than " + std::to_string(kUrdfMaxXmlDepth) +
                           " deep (at byte " + std::to_string(i) + ")");
        }
      }
      i = j + 1;
    }
  }
}

/// The number in `text` if all of it is one finite number (spaces around allowed).
std::optional<double> strictNumber(const char* text) {
  if (text == nullptr) return std::nullopt;
  for (const char* c = text; *c != '\0'; ++c) {
    if (*c == 'x' || *c == 'X') return std::nullopt;  // strtod's hexadecimal, not XML's
  }
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text, &end);
  if (end == text || errno == ERANGE) return std::nullopt;
  while (*end == ' ' || *end == '\t' || *end == '\n' || *end == '\r') ++end;
  if (*end != '\0' || !std::isfinite(v)) return std::nullopt;
  return v;
}

/// urdfdom reads <inertial> leniently: "nan", "1e999", "abc" or "1 2" become a mass of 0 or
/// make it drop the whole element (the link silently massless). Check the text of every
/// <mass> and <inertia> number here; `doc` is the XML urdfdom parses.
void checkInertialText(const TiXmlDocument& doc) {
  const TiXmlElement* robot = doc.RootElement();
  if (robot == nullptr) return;
  for (const TiXmlElement* link = robot->FirstChildElement("link"); link != nullptr;
       link = link->NextSiblingElement("link")) {
    const char* name = link->Attribute("name");
    const std::string element =
        "link '" + std::string(name != nullptr ? name : "?") + "' <inertial>";
    const TiXmlElement* inertial = link->FirstChildElement("inertial");
    if (inertial == nullptr) continue;
    const TiXmlElement* mass = inertial->FirstChildElement("mass");
    const char* mass_text = mass != nullptr ? mass->Attribute("value") : nullptr;
    if (mass_text == nullptr) fail(element, "<mass value> is missing");
    const std::optional<double> m = strictNumber(mass_text);
    if (!m || !(*m > 0.0 && *m <= kUrdfMaxMass)) {
      fail(element, "mass value=\"" + std::string(mass_text) + "\" is not a number in (0, " +
                        num(kUrdfMaxMass) + "] kg (omit <inertial> for a massless link)");
    }
    const TiXmlElement* inertia = inertial->FirstChildElement("inertia");
    if (inertia == nullptr) fail(element, "<inertia> is missing");
    for (const char* key : {"ixx", "ixy", "ixz", "iyy", "iyz", "izz"}) {
      const char* text = inertia->Attribute(key);
      if (text == nullptr) fail(element, std::string("<inertia ") + key + "> is missing");
      if (!strictNumber(text)) {
        fail(element,
             std::string("<inertia ") + key + "=\"" + text + "\"> is not a finite number (kg m^2)");
      }
    }
  }
}

/// The tree as the text declares it, before urdfdom links it: a link that is the child of
/// two joints, or a chain of joints that comes back to where it started, is refused here.
/// (On some later error urdfdom drops a partly built tree whose shared pointers form such
/// a loop, and leaks it.) Joints without a parent or child name are left to urdfdom.
void checkTreeText(const TiXmlDocument& doc) {
  const TiXmlElement* robot = doc.RootElement();
  if (robot == nullptr) return;
  struct Edge {
    std::string parent;
    std::string joint;
  };
  std::map<std::string, Edge> parentOf;  // child link -> (parent link, joint)
  for (const TiXmlElement* joint = robot->FirstChildElement("joint"); joint != nullptr;
       joint = joint->NextSiblingElement("joint")) {
    const TiXmlElement* p = joint->FirstChildElement("parent");
    const TiXmlElement* c = joint->FirstChildElement("child");
    const char* parent = p != nullptr ? p->Attribute("link") : nullptr;
    const char* child = c != nullptr ? c->Attribute("link") : nullptr;
    const char* name = joint->Attribute("name");
    if (parent == nullptr || child == nullptr) continue;
    const std::string joint_name = name != nullptr ? name : "?";
    const auto [it, inserted] = parentOf.emplace(child, Edge{parent, joint_name});
    if (!inserted) {
      throw ModelError("link '" + std::string(child) + "' is the child of two joints ('" +
                       it->second.joint + "' and '" + joint_name +
                       "'): kinematic loops are not supported");
    }
  }
  // Walk up from every link; a walk that meets itself is a loop. Each link is finished once.
  std::map<std::string, int> state;  // 1: on the current walk, 2: finished
  for (const auto& start : parentOf) {
    std::vector<const std::string*> walk;
    const std::string* link = &start.first;
    for (;;) {
      int& st = state[*link];
      if (st == 2) break;
      if (st == 1) {
        throw ModelError("link '" + *link + "' is its own ancestor through joint '" +
                         parentOf.at(*link).joint +
                         "': a kinematic loop, not connected to the root");
      }
      st = 1;
      walk.push_back(link);
      const auto up = parentOf.find(*link);
      if (up == parentOf.end()) break;
      link = &up->second.parent;
    }
    for (const std::string* l : walk) state[*l] = 2;
  }
}

/// An origin (joint placement, inertial frame): finite, within kUrdfMaxDistance of its
/// parent frame, a usable rotation.
void checkPose(const std::string& element, const char* which, const urdf::Pose& pose) {
  const urdf::Vector3& p = pose.position;
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) ||
      !(std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z) <= kUrdfMaxDistance)) {
    fail(element, std::string(which) + " xyz = " + vec(p.x, p.y, p.z) +
                      " must be finite and within " + num(kUrdfMaxDistance) + " m");
  }
  const urdf::Rotation& r = pose.rotation;
  const double n2 = r.x * r.x + r.y * r.y + r.z * r.z + r.w * r.w;
  if (!std::isfinite(n2) || !(n2 > 0.25)) {
    fail(element, std::string(which) + " rotation is not finite (quaternion " + num(r.x) + " " +
                      num(r.y) + " " + num(r.z) + " " + num(r.w) + ")");
  }
}

/// A link's <inertial>: finite origin, mass in (0, kUrdfMaxMass], a rotational inertia that
/// a rigid body can have (symmetric by construction; principal moments >= 0 that satisfy the
/// triangle inequality A + B >= C, relative tolerance kUrdfInertiaTolerance).
void checkInertial(const urdf::Link& link) {
  if (!link.inertial) return;
  const std::string element = "link '" + link.name + "' <inertial>";
  const urdf::Inertial& in = *link.inertial;
  checkPose(element, "origin", in.origin);
  if (!(in.mass > 0.0 && in.mass <= kUrdfMaxMass)) {
    fail(element, "mass = " + num(in.mass) + " kg is not in (0, " + num(kUrdfMaxMass) +
                      "] (omit <inertial> for a massless link)");
  }
  const std::string tensor = "inertia (ixx iyy izz ixy ixz iyz = " + num(in.ixx) + " " +
                             num(in.iyy) + " " + num(in.izz) + " " + num(in.ixy) + " " +
                             num(in.ixz) + " " + num(in.iyz) + ")";
  Eigen::Matrix3d I;
  I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  if (!I.allFinite() || !(I.cwiseAbs().maxCoeff() <= kUrdfMaxInertia)) {
    fail(element,
         tensor + " must be finite with entries within " + num(kUrdfMaxInertia) + " kg m^2");
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(I, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d m = es.eigenvalues();  // ascending
  const double tol = kUrdfInertiaTolerance * std::max(m[2], 0.0);
  if (!(m[0] >= -tol)) {
    fail(element, tensor + " is not positive semidefinite: principal moments " +
                      vec(m[0], m[1], m[2]) + " kg m^2, all must be >= 0");
  }
  if (!(m[0] + m[1] >= m[2] - tol)) {
    fail(element, tensor + " violates the triangle inequality of its principal moments " +
                      vec(m[0], m[1], m[2]) + ": " + num(m[0]) + " + " + num(m[1]) + " < " +
                      num(m[2]) + " (no rigid body has these)");
  }
}

/// A joint's numbers: origin, axis, limits, dynamics.
void checkJoint(const std::string& name, const urdf::Joint& joint) {
  const std::string element = "joint '" + name + "'";
  checkPose(element, "origin", joint.parent_to_joint_origin_transform);
  if (joint.type == urdf::Joint::FIXED) return;
  const urdf::Vector3& a = joint.axis;
  const Eigen::Vector3d axis = toVector(a);
  if (!axis.allFinite() || !(axis.norm() > 1e-12)) {
    fail(element, "axis xyz = " + vec(a.x, a.y, a.z) + " must be finite and non-zero");
  }
  if (joint.limits) {
    const urdf::JointLimits& l = *joint.limits;
    if (joint.type != urdf::Joint::CONTINUOUS) {
      if (!std::isfinite(l.lower) || !std::isfinite(l.upper) || !(l.lower <= l.upper)) {
        fail(element, "<limit> lower = " + num(l.lower) + ", upper = " + num(l.upper) +
                          ": must be finite with lower <= upper");
      }
    }
    if (!(l.velocity >= 0.0) || !std::isfinite(l.velocity)) {
      fail(element,
           "<limit> velocity = " + num(l.velocity) + " must be finite and >= 0 (0: no limit)");
    }
    if (!(l.effort >= 0.0) || !std::isfinite(l.effort)) {
      fail(element, "<limit> effort = " + num(l.effort) + " must be finite and >= 0 (0: no limit)");
    }
  }
  if (joint.dynamics) {
    const urdf::JointDynamics& d = *joint.dynamics;
    if (!(d.damping >= 0.0) || !std::isfinite(d.damping) || !(d.friction >= 0.0) ||
        !std::isfinite(d.friction)) {
      fail(element, "<dynamics> damping = " + num(d.damping) + ", friction = " + num(d.friction) +
                        ": both must be finite and >= 0");
    }
  }
}

struct BodyAccumulator {
  double mass = 0.0;
  Eigen::Vector3d firstMoment = Eigen::Vector3d::Zero();    // body frame
  Eigen::Matrix3d inertiaOrigin = Eigen::Matrix3d::Zero();  // about body origin, body axes
};

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
    traverse(*root);
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
      checkJoint(name, *joint);
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
      if (l->child_links.size() != l->child_joints.size()) {
        throw ModelError("link '" + l->name + "': inconsistent tree from urdfdom");
      }
      for (const auto& c : l->child_links) stack.push_back(c.get());
    }
    for (const auto& [name, link] : urdf_.links_) {
      if (reached.count(name) == 0) {
        throw ModelError("link '" + name + "' is not connected to the root link '" + root.name +
                         "' (kinematic loop or several roots)");
      }
    }
  }

  // A link still to be placed: reached through `joint` (null for the root) from a link
  // placed at (R_bl, p_bl) in body `body`.
  struct Pending {
    const urdf::Link* link;
    const urdf::Joint* joint;
    int body;
    Eigen::Matrix3d R_bl;
    Eigen::Vector3d p_bl;
  };

  // Depth-first (pre-order, children in URDF order) with an explicit stack: the order of
  // bodies, frames and joints is that of the recursive definition, and a chain of any
  // length cannot overflow the call stack.
  void traverse(const urdf::Link& root) {
    std::vector<Pending> stack;
    stack.push_back({&root, nullptr, 0, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()});
    while (!stack.empty()) {
      const Pending item = stack.back();
      stack.pop_back();
      const urdf::Link& link = *item.link;
      int body = item.body;
      Eigen::Matrix3d R_bl = item.R_bl;
      Eigen::Vector3d p_bl = item.p_bl;
      if (item.joint == nullptr) {  // the root: body 0
        Body b;
        b.name = link.name;
        model_.bodies.push_back(b);
        acc_.emplace_back();
      } else {
        const urdf::Joint& joint = *item.joint;
        const Eigen::Matrix3d R_j =
            R_bl * toRotation(joint.parent_to_joint_origin_transform.rotation);
        const Eigen::Vector3d p_j =
            p_bl + R_bl * toVector(joint.parent_to_joint_origin_transform.position);
        if (joint.type == urdf::Joint::FIXED) {  // merged into the parent's body
          R_bl = R_j;
          p_bl = p_j;
        } else {
          body = addBody(link, joint, item.body, R_j, p_j);
          R_bl.setIdentity();
          p_bl.setZero();
        }
      }
      Frame f;
      f.name = link.name;
      f.body = body;
      f.rotation = R_bl;
      f.translation = p_bl;
      model_.frames.push_back(f);
      addInertia(acc_[static_cast<std::size_t>(body)], link, R_bl, p_bl);
      // Reverse order: the first child is taken next.
      for (std::size_t c = link.child_joints.size(); c-- > 0;) {
        stack.push_back({link.child_links[c].get(), link.child_joints[c].get(), body, R_bl, p_bl});
      }
    }
  }

  int addBody(const urdf::Link& child, const urdf::Joint& joint, int parent,
              const Eigen::Matrix3d& R_j, const Eigen::Vector3d& p_j) {
    Body b;
    b.name = child.name;
    b.parent = parent;
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
    return id;
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
    if (m.hasFreeFlyer()) checkCentroidalInertia();
  }

  // A floating base needs the whole robot's rotational inertia about its centre of mass to
  // be positive definite (the centroidal map A_b(q) is inverted); checked at the neutral
  // configuration. Massless or point-mass links are fine as long as the whole is not.
  void checkCentroidalInertia() const {
    const Model& m = model_;
    const auto nb = static_cast<std::size_t>(m.nbodies());
    std::vector<Eigen::Matrix3d> oR(nb, Eigen::Matrix3d::Identity());
    std::vector<Eigen::Vector3d> oc(nb, Eigen::Vector3d::Zero());  // body com in world
    std::vector<Eigen::Vector3d> op(nb, Eigen::Vector3d::Zero());
    Eigen::Vector3d com = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < nb; ++i) {
      const Body& b = m.bodies[i];
      if (b.parent >= 0) {
        const auto p = static_cast<std::size_t>(b.parent);
        oR[i] = oR[p] * b.jointRotation;
        op[i] = op[p] + oR[p] * b.jointTranslation;
      }
      oc[i] = op[i] + oR[i] * b.com;
      com += b.mass * oc[i];
    }
    com /= m.totalMass;
    Eigen::Matrix3d I = Eigen::Matrix3d::Zero();
    for (std::size_t i = 0; i < nb; ++i) {
      const Body& b = m.bodies[i];
      const Eigen::Vector3d d = oc[i] - com;
      I += oR[i] * b.inertia * oR[i].transpose() +
           b.mass * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(I, Eigen::EigenvaluesOnly);
    const Eigen::Vector3d e = es.eigenvalues();
    if (!e.allFinite() || !(e[0] > 1e-12 * e[2])) {
      throw ModelError("URDF '" + m.name +
                       "': the rotational inertia of the whole robot about its centre of mass "
                       "(neutral configuration) has principal moments " +
                       vec(e[0], e[1], e[2]) +
                       " kg m^2; a floating base needs them all > 0 (point masses on a line?)");
    }
  }

  const urdf::ModelInterface& urdf_;
  Model model_;
  std::vector<BodyAccumulator> acc_;
  std::vector<std::array<double, 4>> limits_;
};

}  // namespace

Model buildModelFromUrdfString(const std::string& xml, RootJoint root) {
  // TinyXML (urdfdom's parser) recurses once per nested element: refuse deep nesting here.
  checkXmlNesting(xml);
  {
    TiXmlDocument doc;
    doc.Parse(xml.c_str());
    if (!doc.Error()) {  // else urdfdom reports the syntax error
      checkTreeText(doc);
      checkInertialText(doc);
    }
  }
  CaptureHandler handler;
  console_bridge::useOutputHandler(&handler);
  urdf::ModelInterfaceSharedPtr urdf;
  try {
    urdf = urdf::parseURDF(xml);
  } catch (const std::exception& e) {
    console_bridge::restorePreviousOutputHandler();
    throw ModelError("URDF rejected by urdfdom: " + std::string(e.what()));
  }
  console_bridge::restorePreviousOutputHandler();
  if (!urdf) {
    throw ModelError("URDF rejected by urdfdom: " +
                     (handler.messages.empty() ? std::string("parse error") : handler.messages));
  }
  // urdfdom links hold shared pointers to their children: a kinematic loop would leak the
  // whole tree, and a long chain would be destroyed recursively. Break every link's
  // references when leaving (success or error).
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
  std::string xml;
  try {
    xml = readTextFile(path, "URDF file");
  } catch (const InputError& e) {
    throw ModelError(e.what());
  }
  try {
    return buildModelFromUrdfString(xml, root);
  } catch (const ModelError& e) {
    throw ModelError("URDF file '" + path + "': " + e.what());
  }
}

}  // namespace rollstep::model
