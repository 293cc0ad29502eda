#pragma once
// Umbrella header of the model layer.
#include "rollstep/model/center_of_mass.hpp"
#include "rollstep/model/centroidal.hpp"
#include "rollstep/model/centroidal_derivatives.hpp"
#include "rollstep/model/data.hpp"
#include "rollstep/model/gravity.hpp"
#include "rollstep/model/gravity_derivatives.hpp"
#include "rollstep/model/kinematics.hpp"
#include "rollstep/model/kinematics_derivatives.hpp"
#include "rollstep/model/model.hpp"
#include "rollstep/model/node.hpp"
