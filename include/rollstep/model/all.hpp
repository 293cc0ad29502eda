#pragma once
// Umbrella header of the model layer.
#include "rollstep/model/center-of-mass.hpp"
#include "rollstep/model/centroidal-derivatives.hpp"
#include "rollstep/model/centroidal.hpp"
#include "rollstep/model/data.hpp"
#include "rollstep/model/gravity-derivatives.hpp"
#include "rollstep/model/gravity.hpp"
#include "rollstep/model/kinematics-derivatives.hpp"
#include "rollstep/model/kinematics.hpp"
#include "rollstep/model/model.hpp"
#include "rollstep/model/node.hpp"
