#include "rollstep/centroidal/robot.hpp"

#include <cmath>
#include <stdexcept>

namespace rollstep::centroidal {

namespace {
std::string where(int i) { return "CentroidalRobot: contact " + std::to_string(i); }
}  // namespace

CentroidalRobot::CentroidalRobot(std::shared_ptr<const model::Model> model,
                                 std::vector<ContactDescription> contacts,
                                 std::vector<std::array<int, 2>> side_pairs, double contact_offset)
    : model_(std::move(model)),
      contacts_(std::move(contacts)),
      side_pairs_(std::move(side_pairs)),
      contact_offset_(contact_offset) {
  if (!model_) throw std::invalid_argument("CentroidalRobot: null model");
  if (!model_->hasFreeFlyer()) {
    throw std::invalid_argument("CentroidalRobot: model '" + model_->name +
                                "' has no free-flyer root (the centroidal model needs one)");
  }
  const int n = static_cast<int>(contacts_.size());
  if (n == 0 || n > kMaxContacts) {
    throw std::invalid_argument("CentroidalRobot: " + std::to_string(n) +
                                " contacts, expected 1 to " + std::to_string(kMaxContacts));
  }
  if (!std::isfinite(contact_offset_) || contact_offset_ < 0.0) {
    throw std::invalid_argument("CentroidalRobot: contact_offset " +
                                std::to_string(contact_offset_) +
                                " m, expected a finite value >= 0");
  }
  for (int i = 0; i < n; ++i) {
    const std::string& name = contacts_[static_cast<size_t>(i)].frame;
    if (!model_->existFrame(name)) {
      throw std::invalid_argument(where(i) + ": unknown frame '" + name + "'");
    }
    for (int j = 0; j < i; ++j) {
      if (contacts_[static_cast<size_t>(j)].frame == name) {
        throw std::invalid_argument(where(i) + ": frame '" + name + "' repeated (also contact " +
                                    std::to_string(j) + ")");
      }
    }
    const model::FrameIndex f = model_->getFrameId(name);
    frame_ids_.push_back(f);
    const int body = model_->frames[static_cast<size_t>(f)].body;
    bodies_.push_back(body);
    std::vector<int> cols{0, 1, 2, 3, 4, 5};
    std::vector<int> joints;
    for (int b = body; b > 0; b = model_->bodies[static_cast<size_t>(b)].parent) {
      joints.push_back(model_->bodies[static_cast<size_t>(b)].idxV);
    }
    for (auto it = joints.rbegin(); it != joints.rend(); ++it) cols.push_back(*it);
    support_.push_back(std::move(cols));
  }
  partner_.assign(static_cast<size_t>(n), -1);
  second_.assign(static_cast<size_t>(n), 0);
  for (std::size_t p = 0; p < side_pairs_.size(); ++p) {
    const auto& pair = side_pairs_[p];
    const std::string name = "CentroidalRobot: side pair " + std::to_string(p) + " {" +
                             std::to_string(pair[0]) + ", " + std::to_string(pair[1]) + "}";
    for (int k = 0; k < 2; ++k) {
      if (pair[static_cast<size_t>(k)] < 0 || pair[static_cast<size_t>(k)] >= n) {
        throw std::invalid_argument(name + ": contact index " +
                                    std::to_string(pair[static_cast<size_t>(k)]) +
                                    " out of range [0, " + std::to_string(n - 1) + "]");
      }
    }
    if (pair[0] == pair[1]) throw std::invalid_argument(name + ": a contact paired with itself");
    for (int k = 0; k < 2; ++k) {
      const auto c = static_cast<size_t>(pair[static_cast<size_t>(k)]);
      if (partner_[c] != -1) {
        throw std::invalid_argument(name + ": contact " + std::to_string(c) +
                                    " is already in another pair");
      }
    }
    partner_[static_cast<size_t>(pair[0])] = pair[1];
    partner_[static_cast<size_t>(pair[1])] = pair[0];
    second_[static_cast<size_t>(pair[1])] = 1;
  }
  space_ = std::make_shared<const ocp::SE3xEuclideanSpace>(model_->nj + 6);
}

bool CentroidalRobot::keepsVelocityConstraints(int mode, int i) const {
  if (!inStance(mode, i)) return false;
  const int partner = partnerOf(i);
  if (partner < 0 || !inStance(mode, partner)) return true;
  // Both in stance: only the first of the pair keeps them.
  return second_[static_cast<size_t>(i)] == 0;
}

std::vector<std::string> CentroidalRobot::tangentNames() const {
  std::vector<std::string> names;
  names.reserve(static_cast<std::size_t>(ndx()));
  for (const char* c : {"x", "y", "z"}) names.push_back(std::string("base ") + c);
  for (const char* c : {"x", "y", "z"}) names.push_back(std::string("base rot ") + c);
  for (int j = 0; j < nj(); ++j) {
    names.push_back(model_->jointNames[static_cast<std::size_t>(j)] + " position");
  }
  for (const char* part : {"linear", "angular"}) {
    for (const char* c : {"x", "y", "z"}) {
      names.push_back(std::string("momentum ") + part + " " + c);
    }
  }
  return names;
}

std::vector<std::string> CentroidalRobot::inputNames() const {
  std::vector<std::string> names;
  names.reserve(static_cast<std::size_t>(nu()));
  for (int j = 0; j < nj(); ++j) {
    names.push_back(model_->jointNames[static_cast<std::size_t>(j)] + " velocity");
  }
  for (int i = 0; i < nc(); ++i) {
    for (const char* c : {"x", "y", "z"}) names.push_back(contact(i).frame + " force " + c);
  }
  return names;
}

}  // namespace rollstep::centroidal
