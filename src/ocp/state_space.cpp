#include "rollstep/ocp/state_space.hpp"

#include <stdexcept>

#include "rollstep/lie/se3.hpp"

namespace rollstep::ocp {

// ---- R^n ---------------------------------------------------------------------------------

EuclideanSpace::EuclideanSpace(int n) : n_(n) {
  if (n < 0) throw std::invalid_argument("EuclideanSpace: negative dimension");
}

void EuclideanSpace::neutral(VecRef x) const { x.setZero(); }

void EuclideanSpace::integrate(ConstVecRef x, ConstVecRef dx, VecRef out) const { out = x + dx; }

void EuclideanSpace::difference(ConstVecRef x0, ConstVecRef x1, VecRef out) const { out = x1 - x0; }

void EuclideanSpace::integrateJacobians(ConstVecRef /*x*/, ConstVecRef /*dx*/, MatRef Jx,
                                        MatRef Jdx) const {
  Jx.setIdentity();
  Jdx.setIdentity();
}

void EuclideanSpace::differenceJacobians(ConstVecRef /*x0*/, ConstVecRef /*x1*/, MatRef J0,
                                         MatRef J1) const {
  J0.setIdentity();
  J0 *= -1.0;
  J1.setIdentity();
}

// ---- SE(3) x R^n -------------------------------------------------------------------------

SE3xEuclideanSpace::SE3xEuclideanSpace(int n) : n_(n) {
  if (n < 0) throw std::invalid_argument("SE3xEuclideanSpace: negative dimension");
}

void SE3xEuclideanSpace::neutral(VecRef x) const {
  x.setZero();
  x(6) = 1.0;  // quaternion w
}

void SE3xEuclideanSpace::integrate(ConstVecRef x, ConstVecRef dx, VecRef out) const {
  lie::integrateSE3(x.head<7>(), dx.head<6>(), out.head<7>());
  out.tail(n_) = x.tail(n_) + dx.tail(n_);
}

void SE3xEuclideanSpace::difference(ConstVecRef x0, ConstVecRef x1, VecRef out) const {
  lie::differenceSE3(x0.head<7>(), x1.head<7>(), out.head<6>());
  out.tail(n_) = x1.tail(n_) - x0.tail(n_);
}

void SE3xEuclideanSpace::integrateJacobians(ConstVecRef x, ConstVecRef dx, MatRef Jx,
                                            MatRef Jdx) const {
  Jx.setZero();
  Jdx.setZero();
  lie::integrateSE3Jacobians(x.head<7>(), dx.head<6>(), Jx.topLeftCorner<6, 6>(),
                             Jdx.topLeftCorner<6, 6>());
  Jx.bottomRightCorner(n_, n_).setIdentity();
  Jdx.bottomRightCorner(n_, n_).setIdentity();
}

void SE3xEuclideanSpace::differenceJacobians(ConstVecRef x0, ConstVecRef x1, MatRef J0,
                                             MatRef J1) const {
  J0.setZero();
  J1.setZero();
  lie::differenceSE3Jacobians(x0.head<7>(), x1.head<7>(), J0.topLeftCorner<6, 6>(),
                              J1.topLeftCorner<6, 6>());
  J0.bottomRightCorner(n_, n_).setIdentity();
  J0.bottomRightCorner(n_, n_) *= -1.0;
  J1.bottomRightCorner(n_, n_).setIdentity();
}

void SE3xEuclideanSpace::integrateJacobiansHead(ConstVecRef x, ConstVecRef dx, MatRef Jx,
                                                MatRef Jdx) const {
  lie::integrateSE3Jacobians(x.head<7>(), dx.head<6>(), Jx.topLeftCorner<6, 6>(),
                             Jdx.topLeftCorner<6, 6>());
}

void SE3xEuclideanSpace::differenceJacobiansHead(ConstVecRef x0, ConstVecRef x1, MatRef J0,
                                                 MatRef J1) const {
  lie::differenceSE3Jacobians(x0.head<7>(), x1.head<7>(), J0.topLeftCorner<6, 6>(),
                              J1.topLeftCorner<6, 6>());
}

}  // namespace rollstep::ocp
