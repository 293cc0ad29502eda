// Bindings of the model layer (rollstep/model): Model, Data and the algorithms, Pinocchio
// style. Arrays in are float64 vectors (converted when given otherwise); sizes are checked
// here, since the C++ functions only assert them.
#include <memory>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "rollstep/model/all.hpp"

namespace rollstep::python {

namespace {

using model::Data;
using model::Model;
using ConstVec = Eigen::Ref<const Eigen::VectorXd>;

void checkQ(const Model& model, const ConstVec& q) { checkSize(q.size(), model.nq, "q"); }
void checkV(const Model& model, const ConstVec& v) { checkSize(v.size(), model.nv, "v"); }
void checkData(const Model& model, const Data& data) {
  if (static_cast<int>(data.oRb.size()) != model.nbodies() || data.J.cols() != model.nv) {
    throw std::invalid_argument("data was not made for this model (Data(model))");
  }
}

/// A frame given by index or by name.
model::FrameIndex frameIndex(const Model& model, const py::object& frame) {
  if (py::isinstance<py::str>(frame)) return model.getFrameId(frame.cast<std::string>());
  const int f = frame.cast<int>();
  if (f < 0 || f >= model.nframes()) {
    throw std::out_of_range("frame index " + std::to_string(f) + " out of range [0, " +
                            std::to_string(model.nframes()) + ")");
  }
  return f;
}

std::vector<model::FrameIndex> frameIndices(const Model& model, const py::sequence& frames) {
  std::vector<model::FrameIndex> ids;
  for (const py::handle h : frames)
    ids.push_back(frameIndex(model, py::reinterpret_borrow<py::object>(h)));
  return ids;
}

Eigen::Matrix4d homogeneous(const lie::SE3& placement) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = placement.rotation.toRotationMatrix();
  T.topRightCorner<3, 1>() = placement.translation;
  return T;
}

py::array_t<double> stack3(const std::vector<Eigen::Vector3d>& v) {
  py::array_t<double> a({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}});
  auto r = a.mutable_unchecked<2>();
  for (std::size_t i = 0; i < v.size(); ++i) {
    for (int k = 0; k < 3; ++k) r(static_cast<py::ssize_t>(i), k) = v[i][k];
  }
  return a;
}

py::array_t<double> stack33(const std::vector<Eigen::Matrix3d>& v) {
  py::array_t<double> a({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}, py::ssize_t{3}});
  auto r = a.mutable_unchecked<3>();
  for (std::size_t i = 0; i < v.size(); ++i) {
    for (int j = 0; j < 3; ++j) {
      for (int k = 0; k < 3; ++k) r(static_cast<py::ssize_t>(i), j, k) = v[i](j, k);
    }
  }
  return a;
}

void checkForces(const Model& model, const std::vector<model::FrameIndex>& frames,
                 const ConstVec& forces) {
  (void)model;
  checkSize(forces.size(), 3 * static_cast<Eigen::Index>(frames.size()),
            "forces (3 per frame, stacked)");
}

}  // namespace

void bindModel(py::module_& m) {
  py::enum_<model::ReferenceFrame>(
      m, "ReferenceFrame",
      "Frame in which a velocity or Jacobian is expressed (Pinocchio's meaning). Six-vectors "
      "are [linear (3); angular (3)].\n"
      "  LOCAL: the frame's own axes, linear velocity of the frame origin;\n"
      "  WORLD: world axes, spatial velocity at the world origin;\n"
      "  LOCAL_WORLD_ALIGNED: world axes, linear velocity of the frame origin.")
      .value("LOCAL", model::ReferenceFrame::LOCAL)
      .value("WORLD", model::ReferenceFrame::WORLD)
      .value("LOCAL_WORLD_ALIGNED", model::ReferenceFrame::LOCAL_WORLD_ALIGNED);

  py::class_<Model, std::shared_ptr<Model>>(
      m, "Model",
      "Immutable rigid-body tree of a robot (from a URDF; fixed joints merged into their "
      "parent). Units SI (m, rad, kg, N, s).\n\n"
      "Free-flyer root: q = [p (3, world, m), quaternion x y z w (4, base->world), q_J (nj)], "
      "v = [v_lin (3, m/s), omega (3, rad/s), v_J (nj)] with the base twist in the base LOCAL "
      "frame; a tangent perturbation dq = [dq_b (6, local, SE(3) right-plus), dq_J]: every "
      "derivative 'w.r.t. q' is w.r.t. dq. Fixed root: q = q_J, v = v_J. Joints are 1-DoF "
      "(revolute [rad], prismatic [m]) in depth-first URDF order (joint_names).\n\n"
      "Build one with build_model_from_urdf(path) or load_robot_model(folder).")
      .def_readonly("name", &Model::name, "Robot name (URDF).")
      .def_readonly("nq", &Model::nq, "Configuration size (7 + nj with a free flyer).")
      .def_readonly("nv", &Model::nv, "Velocity / tangent size (6 + nj with a free flyer).")
      .def_readonly("nj", &Model::nj, "Number of 1-DoF joints.")
      .def_readonly("nq_base", &Model::nqBase, "7 for a free flyer, 0 for a fixed root.")
      .def_readonly("nv_base", &Model::nvBase, "6 for a free flyer, 0 for a fixed root.")
      .def_property_readonly("nbodies", &Model::nbodies, "Bodies after merging fixed joints.")
      .def_property_readonly("nframes", &Model::nframes,
                             "Frames (one per URDF link, merged ones included).")
      .def_property_readonly("has_free_flyer", &Model::hasFreeFlyer, "True for a free-flyer root.")
      .def_readonly("joint_names", &Model::jointNames,
                    "Joint names: joint j is q[nq_base + j], v[nv_base + j].")
      .def_property_readonly(
          "frame_names",
          [](const Model& mo) {
            std::vector<std::string> names;
            for (const model::Frame& f : mo.frames) names.push_back(f.name);
            return names;
          },
          "Frame names, in frame index order.")
      .def_property_readonly(
          "body_names",
          [](const Model& mo) {
            std::vector<std::string> names;
            for (const model::Body& b : mo.bodies) names.push_back(b.name);
            return names;
          },
          "Body names (the URDF link carrying each body frame), depth-first.")
      .def_readonly("lower_position_limit", &Model::lowerPositionLimit,
                    "Joint lower limits (nj) [rad or m]; -inf for continuous joints.")
      .def_readonly("upper_position_limit", &Model::upperPositionLimit,
                    "Joint upper limits (nj) [rad or m]; +inf for continuous joints.")
      .def_readonly("velocity_limit", &Model::velocityLimit,
                    "Joint velocity limits (nj) [rad/s or m/s]; 0: none.")
      .def_readonly("effort_limit", &Model::effortLimit,
                    "Joint effort limits (nj) [N m or N]; 0: none.")
      .def_readonly("gravity", &Model::gravity, "Gravity (3) [m/s^2], world frame.")
      .def_readonly("total_mass", &Model::totalMass, "Total mass [kg].")
      .def("get_frame_id", &Model::getFrameId, py::arg("name"),
           "Frame index by name; IndexError naming the frame if absent.")
      .def("exist_frame", &Model::existFrame, py::arg("name"),
           "Whether a frame of that name exists.")
      .def("get_joint_id", &Model::getJointId, py::arg("name"),
           "Joint index j (0..nj-1) by name; IndexError if absent.")
      .def("__repr__", [](const Model& mo) {
        return "<rollstep.Model '" + mo.name + "' nq=" + std::to_string(mo.nq) +
               " nv=" + std::to_string(mo.nv) + " frames=" + std::to_string(mo.nframes()) + ">";
      });

  m.def(
      "build_model_from_urdf",
      [](const py::object& path, bool fixed_base) {
        return std::make_shared<Model>(model::buildModelFromUrdfFile(
            pathString(path), fixed_base ? model::RootJoint::Fixed : model::RootJoint::FreeFlyer));
      },
      py::arg("path"), py::arg("fixed_base") = false,
      "Loads a URDF file into a Model (free-flyer root unless fixed_base). Raises ModelError "
      "naming the file, element, value and valid range for a URDF that cannot be used.");
  m.def(
      "build_model_from_urdf_string",
      [](const std::string& xml, bool fixed_base) {
        return std::make_shared<Model>(model::buildModelFromUrdfString(
            xml, fixed_base ? model::RootJoint::Fixed : model::RootJoint::FreeFlyer));
      },
      py::arg("xml"), py::arg("fixed_base") = false,
      "Same as build_model_from_urdf from the URDF's XML text.");

  py::class_<Data>(
      m, "Data",
      "Mutable workspace of the model algorithms, made once per Model: Data(model). Every "
      "algorithm writes its results here; which attributes are valid depends on which "
      "algorithm ran last (each function says what it fills). Matrix attributes are "
      "read-only numpy views of the workspace (no copy): copy them to keep values across "
      "calls. World frame, SI units.")
      .def(py::init<const Model&>(), py::arg("model"))
      .def_property_readonly(
          "oRb", [](const Data& d) { return stack33(d.oRb); },
          "(nbodies, 3, 3) world rotation of each body (forward_kinematics).")
      .def_property_readonly(
          "opb", [](const Data& d) { return stack3(d.opb); },
          "(nbodies, 3) world position of each body origin [m].")
      .def_property_readonly(
          "oRf", [](const Data& d) { return stack33(d.oRf); },
          "(nframes, 3, 3) world rotation of each frame "
          "(update_frame_placements).")
      .def_property_readonly(
          "opf", [](const Data& d) { return stack3(d.opf); },
          "(nframes, 3) world position of each frame origin [m].")
      .def_readonly("J", &Data::J,
                    "(6, nv) world joint Jacobian: column k is the world spatial motion "
                    "[linear at the world origin; angular] of a unit dv_k "
                    "(compute_joint_jacobians).")
      .def_readonly("com", &Data::com, "(3,) centre of mass, world [m] (center_of_mass).")
      .def_readonly("Jcom", &Data::Jcom,
                    "(3, nv) d com / dq = d com_dot / dv (jacobian_center_of_mass).")
      .def_readonly("Ag", &Data::Ag,
                    "(6, nv) centroidal momentum matrix: h = Ag v = [linear (kg m/s); angular "
                    "about the com (kg m^2/s)], world axes (compute_centroidal_map).")
      .def_readonly("hg", &Data::hg,
                    "(6,) centroidal momentum [linear; angular about the com], world axes "
                    "(compute_centroidal_momentum).")
      .def_readonly("dhg_dq", &Data::dhg_dq,
                    "(6, nv) d(Ag(q) v)/dq at fixed v (compute_centroidal_momentum_derivatives).")
      .def_readonly("g", &Data::g, "(nv,) generalized gravity (compute_generalized_gravity).")
      .def_readonly("dg_dq", &Data::dg_dq, "(nv, nv) d g / dq.")
      .def_readonly("tau_contact", &Data::tauContact,
                    "(nv,) sum_c J_c(q)^T f_c (compute_contact_torque).")
      .def_readonly("dtau_contact_dq", &Data::dtauContact_dq,
                    "(nv, nv) d(J^T f)/dq at fixed world forces.")
      .def_readonly("tau_static", &Data::tauStatic,
                    "(nv,) g(q) - J(q)^T f, f acting on the robot (compute_static_torque).");

  m.def("neutral_configuration", &model::neutralConfiguration, py::arg("model"),
        "Neutral configuration q (nq): zero position, identity quaternion, zero joints.");
  m.def(
      "integrate",
      [](const Model& mo, const ConstVec& q, const ConstVec& v) {
        checkQ(mo, q);
        checkV(mo, v);
        Eigen::VectorXd out(mo.nq);
        model::integrate(mo, q, v, out);
        return out;
      },
      py::arg("model"), py::arg("q"), py::arg("v"),
      "q (+) v (nq): SE(3) right-plus on the free flyer (v's base part in the base LOCAL "
      "frame), addition on the joints.");
  m.def(
      "difference",
      [](const Model& mo, const ConstVec& q0, const ConstVec& q1) {
        checkQ(mo, q0);
        checkQ(mo, q1);
        Eigen::VectorXd dv(mo.nv);
        model::difference(mo, q0, q1, dv);
        return dv;
      },
      py::arg("model"), py::arg("q0"), py::arg("q1"),
      "dv = q1 (-) q0 (nv), the inverse of integrate: integrate(q0, dv) = q1.");

  m.def(
      "forward_kinematics",
      [](const Model& mo, Data& d, const ConstVec& q, const std::optional<Eigen::VectorXd>& v) {
        checkData(mo, d);
        checkQ(mo, q);
        if (v) {
          checkV(mo, *v);
          model::forwardKinematics(mo, d, q, *v);
        } else {
          model::forwardKinematics(mo, d, q);
        }
      },
      py::arg("model"), py::arg("data"), py::arg("q"), py::arg("v") = py::none(),
      "Body placements (data.oRb, data.opb); with v also the body velocities and the world "
      "joint Jacobian data.J.");
  m.def(
      "update_frame_placements",
      [](const Model& mo, Data& d) {
        checkData(mo, d);
        model::updateFramePlacements(mo, d);
      },
      py::arg("model"), py::arg("data"),
      "Frame placements (data.oRf, data.opf) from the body placements (after "
      "forward_kinematics).");
  m.def(
      "update_frame_placement",
      [](const Model& mo, Data& d, const py::object& frame) {
        checkData(mo, d);
        model::updateFramePlacement(mo, d, frameIndex(mo, frame));
      },
      py::arg("model"), py::arg("data"), py::arg("frame"),
      "One frame's placement (data.oRf[f], data.opf[f]) from the body placements (after "
      "forward_kinematics).");
  m.def(
      "get_frame_placement",
      [](const Model& mo, Data& d, const py::object& frame) {
        checkData(mo, d);
        return homogeneous(model::getFramePlacement(mo, d, frameIndex(mo, frame)));
      },
      py::arg("model"), py::arg("data"), py::arg("frame"),
      "World placement of a frame (index or name) as a 4x4 homogeneous matrix [R p; 0 1] "
      "(R: frame->world rotation, p: origin [m]); after forward_kinematics.");
  m.def(
      "get_frame_velocity",
      [](const Model& mo, Data& d, const py::object& frame, model::ReferenceFrame rf) {
        checkData(mo, d);
        return Eigen::VectorXd(model::getFrameVelocity(mo, d, frameIndex(mo, frame), rf));
      },
      py::arg("model"), py::arg("data"), py::arg("frame"),
      py::arg("reference_frame") = model::ReferenceFrame::LOCAL,
      "Spatial velocity (6,) [linear (m/s); angular (rad/s)] of a frame in reference_frame, "
      "after forward_kinematics(model, data, q, v).");
  m.def(
      "compute_joint_jacobians",
      [](const Model& mo, Data& d, const ConstVec& q) {
        checkData(mo, d);
        checkQ(mo, q);
        model::computeJointJacobians(mo, d, q);
        return Eigen::MatrixXd(d.J);
      },
      py::arg("model"), py::arg("data"), py::arg("q"),
      "Placements and the world joint Jacobian data.J (6, nv); returns a copy of data.J.");
  m.def(
      "get_frame_jacobian",
      [](const Model& mo, Data& d, const py::object& frame, model::ReferenceFrame rf) {
        checkData(mo, d);
        Eigen::MatrixXd J(6, mo.nv);
        model::getFrameJacobian(mo, d, frameIndex(mo, frame), rf, J);
        return J;
      },
      py::arg("model"), py::arg("data"), py::arg("frame"),
      py::arg("reference_frame") = model::ReferenceFrame::LOCAL,
      "Frame Jacobian (6, nv), [linear; angular] rows, with get_frame_velocity = J v, after "
      "compute_joint_jacobians (or forward_kinematics with v). Columns outside the frame's "
      "support are zero.");
  m.def(
      "compute_forward_kinematics_derivatives",
      [](const Model& mo, Data& d, const ConstVec& q, const ConstVec& v) {
        checkData(mo, d);
        checkQ(mo, q);
        checkV(mo, v);
        model::computeForwardKinematicsDerivatives(mo, d, q, v);
      },
      py::arg("model"), py::arg("data"), py::arg("q"), py::arg("v"),
      "Placements, velocities and joint Jacobians: call before "
      "get_frame_position_derivative and get_frame_linear_velocity_derivatives.");
  m.def(
      "get_frame_position_derivative",
      [](const Model& mo, Data& d, const py::object& frame) {
        checkData(mo, d);
        Eigen::MatrixXd dp(3, mo.nv);
        model::getFramePositionDerivative(mo, d, frameIndex(mo, frame), dp);
        return dp;
      },
      py::arg("model"), py::arg("data"), py::arg("frame"),
      "d p_f / dq (3, nv): world position [m] of the frame origin w.r.t. the tangent dq (the "
      "linear rows of the LOCAL_WORLD_ALIGNED frame Jacobian).");
  m.def(
      "get_frame_linear_velocity_derivatives",
      [](const Model& mo, Data& d, const py::object& frame) {
        checkData(mo, d);
        Eigen::MatrixXd dv_dq(3, mo.nv), dv_dv(3, mo.nv);
        model::getFrameLinearVelocityDerivatives(mo, d, frameIndex(mo, frame), dv_dq, dv_dv);
        return py::make_tuple(dv_dq, dv_dv);
      },
      py::arg("model"), py::arg("data"), py::arg("frame"),
      "(dv_dq, dv_dv), each (3, nv): derivatives of the world linear velocity [m/s] of the "
      "frame origin v_f = J_lin(q) v w.r.t. the tangent dq and v.");
  m.def(
      "center_of_mass",
      [](const Model& mo, Data& d, const ConstVec& q) {
        checkData(mo, d);
        checkQ(mo, q);
        return Eigen::Vector3d(model::centerOfMass(mo, d, q));
      },
      py::arg("model"), py::arg("data"), py::arg("q"),
      "World centre of mass (3,) [m]; fills data.com.");
  m.def(
      "jacobian_center_of_mass",
      [](const Model& mo, Data& d, const ConstVec& q) {
        checkData(mo, d);
        checkQ(mo, q);
        return Eigen::MatrixXd(model::jacobianCenterOfMass(mo, d, q));
      },
      py::arg("model"), py::arg("data"), py::arg("q"),
      "d com / dq = d com_dot / dv (3, nv) [m per unit of dq]; fills data.Jcom, data.com.");
  m.def(
      "compute_centroidal_map",
      [](const Model& mo, Data& d, const ConstVec& q) {
        checkData(mo, d);
        checkQ(mo, q);
        return Eigen::MatrixXd(model::computeCentroidalMap(mo, d, q));
      },
      py::arg("model"), py::arg("data"), py::arg("q"),
      "Centroidal momentum matrix Ag (6, nv): h = Ag v = [linear (kg m/s); angular about "
      "the com (kg m^2/s)], world axes; fills data.Ag.");
  m.def(
      "compute_centroidal_momentum",
      [](const Model& mo, Data& d, const ConstVec& q, const ConstVec& v) {
        checkData(mo, d);
        checkQ(mo, q);
        checkV(mo, v);
        return Eigen::VectorXd(model::computeCentroidalMomentum(mo, d, q, v));
      },
      py::arg("model"), py::arg("data"), py::arg("q"), py::arg("v"),
      "Centroidal momentum h = Ag(q) v (6,) [linear (kg m/s); angular about the com "
      "(kg m^2/s)], world axes; fills data.hg, data.Ag.");
  m.def(
      "compute_centroidal_momentum_derivatives",
      [](const Model& mo, Data& d, const ConstVec& q, const ConstVec& v) {
        checkData(mo, d);
        checkQ(mo, q);
        checkV(mo, v);
        model::computeCentroidalMomentumDerivatives(mo, d, q, v);
        return py::make_tuple(Eigen::MatrixXd(d.dhg_dq), Eigen::MatrixXd(d.Ag));
      },
      py::arg("model"), py::arg("data"), py::arg("q"), py::arg("v"),
      "(dh_dq, dh_dv), each (6, nv): derivatives of h = Ag(q) v w.r.t. the tangent dq (at "
      "fixed v) and v (= Ag); fills data.dhg_dq, data.hg, data.Ag.");
  m.def(
      "compute_generalized_gravity",
      [](const Model& mo, Data& d, const ConstVec& q) {
        checkData(mo, d);
        checkQ(mo, q);
        return Eigen::VectorXd(model::computeGeneralizedGravity(mo, d, q));
      },
      py::arg("model"), py::arg("data"), py::arg("q"),
      "Generalized gravity g(q) (nv,) [N, N m]: the generalized force holding the robot "
      "against gravity; free-flyer part in the base LOCAL frame [force; torque about the "
      "base origin]. Fills data.g.");
  m.def(
      "compute_generalized_gravity_derivatives",
      [](const Model& mo, Data& d, const ConstVec& q) {
        checkData(mo, d);
        checkQ(mo, q);
        return Eigen::MatrixXd(model::computeGeneralizedGravityDerivatives(mo, d, q));
      },
      py::arg("model"), py::arg("data"), py::arg("q"),
      "dg/dq (nv, nv) w.r.t. the tangent dq; fills data.dg_dq and data.g.");
  m.def(
      "compute_contact_torque",
      [](const Model& mo, Data& d, const ConstVec& q, const py::sequence& frames,
         const ConstVec& forces) {
        checkData(mo, d);
        checkQ(mo, q);
        const std::vector<model::FrameIndex> ids = frameIndices(mo, frames);
        checkForces(mo, ids, forces);
        return Eigen::VectorXd(model::computeContactTorque(mo, d, q, ids, forces));
      },
      py::arg("model"), py::arg("data"), py::arg("q"), py::arg("frames"), py::arg("forces"),
      "sum_c J_c(q)^T f_c (nv,): f_c world-frame forces [N] at the origins of `frames` "
      "(indices or names), stacked 3 per frame; J_c the linear rows of the "
      "LOCAL_WORLD_ALIGNED Jacobian. Fills data.tau_contact.");
  m.def(
      "compute_static_torque",
      [](const Model& mo, Data& d, const ConstVec& q, const py::sequence& frames,
         const ConstVec& forces) {
        checkData(mo, d);
        checkQ(mo, q);
        const std::vector<model::FrameIndex> ids = frameIndices(mo, frames);
        checkForces(mo, ids, forces);
        return Eigen::VectorXd(model::computeStaticTorque(mo, d, q, ids, forces));
      },
      py::arg("model"), py::arg("data"), py::arg("q"), py::arg("frames"), py::arg("forces"),
      "g(q) - J(q)^T f (nv,) with f the world forces [N] acting ON the robot at the frames' "
      "origins: its last nj rows are the static joint torques [N m or N]; the base rows "
      "vanish at a static equilibrium. Fills data.tau_static.");
  m.def(
      "compute_contact_torque_derivatives",
      [](const Model& mo, Data& d, const ConstVec& q, const py::sequence& frames,
         const ConstVec& forces) {
        checkData(mo, d);
        checkQ(mo, q);
        const std::vector<model::FrameIndex> ids = frameIndices(mo, frames);
        checkForces(mo, ids, forces);
        return Eigen::MatrixXd(model::computeContactTorqueDerivatives(mo, d, q, ids, forces));
      },
      py::arg("model"), py::arg("data"), py::arg("q"), py::arg("frames"), py::arg("forces"),
      "d(J(q)^T f)/dq (nv, nv) at fixed world forces, w.r.t. the tangent dq; fills "
      "data.dtau_contact_dq.");
}

}  // namespace rollstep::python
