#include "rollstep/model/model.hpp"

#include <stdexcept>

#include "rollstep/lie/se3.hpp"
#include "rollstep/model/data.hpp"

namespace rollstep::model {

FrameIndex Model::getFrameId(const std::string& frame_name) const {
  for (int i = 0; i < nframes(); ++i) {
    if (frames[static_cast<std::size_t>(i)].name == frame_name) return i;
  }
  throw std::out_of_range("model '" + name + "' has no frame '" + frame_name + "'");
}

bool Model::existFrame(const std::string& frame_name) const {
  for (const Frame& f : frames) {
    if (f.name == frame_name) return true;
  }
  return false;
}

int Model::getJointId(const std::string& joint_name) const {
  for (int j = 0; j < nj; ++j) {
    if (jointNames[static_cast<std::size_t>(j)] == joint_name) return j;
  }
  throw std::out_of_range("model '" + name + "' has no joint '" + joint_name + "'");
}

Eigen::VectorXd neutralConfiguration(const Model& model) {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(model.nq);
  if (model.hasFreeFlyer()) q[6] = 1.0;
  return q;
}

void integrate(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q,
               const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::Ref<Eigen::VectorXd> qout) {
  if (model.hasFreeFlyer()) {
    lie::integrateSE3(q.head<7>(), v.head<6>(), qout.head<7>());
  }
  qout.tail(model.nj) = q.tail(model.nj) + v.tail(model.nj);
}

void difference(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q0,
                const Eigen::Ref<const Eigen::VectorXd>& q1, Eigen::Ref<Eigen::VectorXd> dv) {
  if (model.hasFreeFlyer()) {
    lie::differenceSE3(q0.head<7>(), q1.head<7>(), dv.head<6>());
  }
  dv.tail(model.nj) = q1.tail(model.nj) - q0.tail(model.nj);
}

Data::Data(const Model& model) {
  const auto nb = static_cast<std::size_t>(model.nbodies());
  const auto nf = static_cast<std::size_t>(model.nframes());
  const int nv = model.nv;
  oRb.assign(nb, Eigen::Matrix3d::Identity());
  opb.assign(nb, Eigen::Vector3d::Zero());
  ov.assign(nb, Vector6d::Zero());
  oRf.assign(nf, Eigen::Matrix3d::Identity());
  opf.assign(nf, Eigen::Vector3d::Zero());
  J = Matrix6Xd::Zero(6, nv);
  ocom.assign(nb, Eigen::Vector3d::Zero());
  subtreeMoment.assign(nb, Eigen::Vector3d::Zero());
  bodyInertia.assign(nb, Eigen::Matrix3d::Zero());
  subtreeInertia.assign(nb, Eigen::Matrix3d::Zero());
  subtreeMomentum.assign(nb, Vector6d::Zero());
  Jcom = Eigen::Matrix3Xd::Zero(3, nv);
  Ag = Matrix6Xd::Zero(6, nv);
  dhg_dq = Matrix6Xd::Zero(6, nv);
  g = Eigen::VectorXd::Zero(nv);
  dg_dq = Eigen::MatrixXd::Zero(nv, nv);
  tauContact = Eigen::VectorXd::Zero(nv);
  dtauContact_dq = Eigen::MatrixXd::Zero(nv, nv);
  tauStatic = Eigen::VectorXd::Zero(nv);
  Y = Eigen::Matrix3Xd::Zero(3, nv);
  frameJ = Eigen::Matrix3Xd::Zero(3, nv);
}

}  // namespace rollstep::model
