#include "rollstep/ocp/problem.hpp"

#include <cmath>
#include <stdexcept>

namespace rollstep::ocp {

namespace {
void checkDims(const char* what, const std::string& name, int ndx, int nu, int pndx, int pnu) {
  if (ndx != pndx || nu != pnu) {
    throw std::invalid_argument(std::string("OptimalControlProblem: ") + what + " '" + name +
                                "' has ndx=" + std::to_string(ndx) + ", nu=" + std::to_string(nu) +
                                " but the problem has ndx=" + std::to_string(pndx) +
                                ", nu=" + std::to_string(pnu));
  }
}

void checkSoftBounds(const char* where, const InequalityOptions& options) {
  const std::string prefix = std::string("OptimalControlProblem::") + where + ": soft bounds need ";
  if (options.soft && !(options.relaxation > 0.0)) {
    throw std::invalid_argument(prefix + "a positive relaxation");
  }
  if (options.soft && !(options.weight > 0.0 && std::isfinite(options.weight))) {
    throw std::invalid_argument(prefix + "a positive finite weight");
  }
}

BoundSet makeBounds(const VectorXd& lower, const VectorXd& upper, InequalityOptions options) {
  BoundSet b;
  b.options = options;
  int count = 0;
  for (int i = 0; i < lower.size(); ++i) {
    if (std::isfinite(lower(i)) || std::isfinite(upper(i))) ++count;
  }
  b.lower = VectorXd::Zero(count);
  b.upper = VectorXd::Zero(count);
  int j = 0;
  for (int i = 0; i < lower.size(); ++i) {
    const bool lo = std::isfinite(lower(i)), hi = std::isfinite(upper(i));
    if (!lo && !hi) continue;
    b.index.push_back(i);
    b.has_lower.push_back(lo);
    b.has_upper.push_back(hi);
    b.lower(j) = lo ? lower(i) : 0.0;
    b.upper(j) = hi ? upper(i) : 0.0;
    ++j;
  }
  return b;
}

void checkBoundValues(const char* what, const VectorXd& lower, const VectorXd& upper, int n) {
  if (lower.size() != n || upper.size() != n) {
    throw std::invalid_argument(
        std::string("OptimalControlProblem::") + what + ": need " + std::to_string(n) +
        " entries, got " + std::to_string(lower.size()) + " and " + std::to_string(upper.size()));
  }
  for (int i = 0; i < n; ++i) {
    if (std::isnan(lower(i)) || std::isnan(upper(i)) || lower(i) > upper(i) ||
        lower(i) == OptimalControlProblem::kInfinity ||
        upper(i) == -OptimalControlProblem::kInfinity) {
      throw std::invalid_argument(std::string("OptimalControlProblem::") + what + ": entry " +
                                  std::to_string(i) + " has lower " + std::to_string(lower(i)) +
                                  " > upper " + std::to_string(upper(i)) + " (or NaN)");
    }
  }
}
}  // namespace

OptimalControlProblem::OptimalControlProblem(std::shared_ptr<const Dynamics> dynamics, int horizon,
                                             double dt, int schedule_capacity)
    : dynamics_(std::move(dynamics)), horizon_(horizon), dt_(dt), schedule_(schedule_capacity) {
  if (!dynamics_) throw std::invalid_argument("OptimalControlProblem: null dynamics");
  if (horizon < 1) throw std::invalid_argument("OptimalControlProblem: horizon must be >= 1");
  if (!(dt > 0.0) || !std::isfinite(dt)) {
    throw std::invalid_argument("OptimalControlProblem: dt must be positive and finite");
  }
  input_bounds_.options = {};
  state_bounds_.options = {};
}

void OptimalControlProblem::setPrecomputation(std::shared_ptr<const NodePrecomputation> pre) {
  pre_ = std::move(pre);
}

void OptimalControlProblem::addCost(std::string name, std::shared_ptr<const CostTerm> cost,
                                    Stage stage) {
  if (!cost)
    throw std::invalid_argument("OptimalControlProblem::addCost: null term '" + name + "'");
  checkDims("cost", name, cost->ndx(), cost->nu(), ndx(), nu());
  if (appliesTo(stage, true) && cost->dependsOnInput()) {
    throw std::invalid_argument("OptimalControlProblem::addCost: terminal cost '" + name +
                                "' must not depend on the input");
  }
  costs_.push_back({std::move(cost), stage});
  cost_names_.push_back(std::move(name));
}

void OptimalControlProblem::addEquality(std::string name,
                                        std::shared_ptr<const Residual> residual) {
  if (!residual) {
    throw std::invalid_argument("OptimalControlProblem::addEquality: null residual '" + name + "'");
  }
  checkDims("equality", name, residual->ndx(), residual->nu(), ndx(), nu());
  max_eq_ += residual->maxRows();
  equalities_.push_back(std::move(residual));
  eq_names_.push_back(std::move(name));
}

void OptimalControlProblem::addInequality(std::string name,
                                          std::shared_ptr<const Residual> residual, Stage stage,
                                          InequalityOptions options) {
  if (!residual) {
    throw std::invalid_argument("OptimalControlProblem::addInequality: null residual '" + name +
                                "'");
  }
  checkDims("inequality", name, residual->ndx(), residual->nu(), ndx(), nu());
  if ((appliesTo(stage, true) || options.soft) && residual->dependsOnInput()) {
    throw std::invalid_argument("OptimalControlProblem::addInequality: '" + name +
                                "' is terminal or soft and must not depend on the input");
  }
  if (options.soft && !(options.relaxation > 0.0)) {
    throw std::invalid_argument("OptimalControlProblem::addInequality: '" + name +
                                "' needs a positive relaxation");
  }
  if (options.soft && !(options.weight > 0.0 && std::isfinite(options.weight))) {
    throw std::invalid_argument("OptimalControlProblem::addInequality: '" + name +
                                "' needs a positive finite soft weight");
  }
  max_ineq_ += residual->maxRows();
  inequalities_.push_back({std::move(residual), stage, options});
  ineq_names_.push_back(std::move(name));
}

void OptimalControlProblem::setCoordinateNames(std::vector<std::string> tangent,
                                               std::vector<std::string> inputs) {
  const auto check = [](const std::vector<std::string>& names, int size, const char* what) {
    if (!names.empty() && static_cast<int>(names.size()) != size) {
      throw std::invalid_argument(
          "OptimalControlProblem::setCoordinateNames: " + std::to_string(names.size()) + " " +
          what + " names for " + std::to_string(size) + " coordinates");
    }
  };
  check(tangent, ndx(), "tangent");
  check(inputs, nu(), "input");
  tangent_names_ = std::move(tangent);
  input_names_ = std::move(inputs);
}

std::string OptimalControlProblem::tangentName(int i) const {
  if (i >= 0 && i < static_cast<int>(tangent_names_.size())) {
    return tangent_names_[static_cast<std::size_t>(i)];
  }
  return "tangent " + std::to_string(i);
}

std::string OptimalControlProblem::inputName(int i) const {
  if (i >= 0 && i < static_cast<int>(input_names_.size())) {
    return input_names_[static_cast<std::size_t>(i)];
  }
  return "input " + std::to_string(i);
}

void OptimalControlProblem::setInputBounds(const VectorXd& lower, const VectorXd& upper,
                                           InequalityOptions options) {
  checkBoundValues("setInputBounds", lower, upper, nu());
  checkSoftBounds("setInputBounds", options);
  input_bounds_ = makeBounds(lower, upper, options);
}

void OptimalControlProblem::setStateBounds(const VectorXd& lower, const VectorXd& upper,
                                           InequalityOptions options) {
  checkBoundValues("setStateBounds", lower, upper, ndx());
  const int off = stateSpace().euclideanTangentOffset();
  for (int i = 0; i < off; ++i) {
    if (std::isfinite(lower(i)) || std::isfinite(upper(i))) {
      throw std::invalid_argument("OptimalControlProblem::setStateBounds: tangent coordinate " +
                                  std::to_string(i) +
                                  " is not Euclidean; its bounds must be infinite");
    }
  }
  checkSoftBounds("setStateBounds", options);
  state_bounds_ = makeBounds(lower, upper, options);
}

NodeContext OptimalControlProblem::context(int k) const {
  NodeContext c;
  c.node = k;
  c.terminal = (k == horizon_);
  c.time = t0_ + k * dt_;
  c.dt = c.terminal ? 0.0 : dt_;
  c.mode = schedule_.modeAt(c.time);
  c.schedule = &schedule_;
  return c;
}

std::unique_ptr<NodeData> OptimalControlProblem::createNodeBlocks() const {
  auto d = std::make_unique<NodeData>();
  const int n = ndx(), m = nu();
  d->lx = VectorXd::Zero(n);
  d->lu = VectorXd::Zero(m);
  d->Lxx = MatrixXd::Zero(n, n);
  d->Luu = MatrixXd::Zero(m, m);
  d->Lux = MatrixXd::Zero(m, n);
  d->xnext = VectorXd::Zero(nx());
  d->Fx = MatrixXd::Zero(n, n);
  d->Fu = MatrixXd::Zero(n, m);
  d->e = VectorXd::Zero(max_eq_);
  d->Ex = MatrixXd::Zero(max_eq_, n);
  d->Eu = MatrixXd::Zero(max_eq_, m);
  d->g = VectorXd::Zero(max_ineq_);
  d->Gx = MatrixXd::Zero(max_ineq_, n);
  d->Gu = MatrixXd::Zero(max_ineq_, m);
  d->soft = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(max_ineq_, false);
  d->state_only = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(max_ineq_, false);
  d->relaxation = VectorXd::Zero(max_ineq_);
  d->soft_weight = VectorXd::Zero(max_ineq_);
  d->mirror = Eigen::VectorXi::Constant(max_ineq_, -1);
  d->zero_input = VectorXd::Zero(m);
  return d;
}

std::unique_ptr<NodeData> OptimalControlProblem::createNodeData() const {
  auto d = createNodeBlocks();
  if (!pre_) {
    d->dynamics_data = dynamics_->createData();
    for (const auto& c : costs_) d->cost_data.push_back(c.term->createData());
    for (const auto& e : equalities_) d->equality_data.push_back(e->createData());
    for (const auto& g : inequalities_) d->inequality_data.push_back(g.residual->createData());
    return d;
  }
  // run() passes the node cache to every call: the terms need no caches of their own.
  d->cache = pre_->createCache();
  d->dynamics_data = dynamics_->createDataWithNodeCache();
  for (const auto& c : costs_) d->cost_data.push_back(c.term->createDataWithNodeCache());
  for (const auto& e : equalities_) d->equality_data.push_back(e->createDataWithNodeCache());
  for (const auto& g : inequalities_) {
    d->inequality_data.push_back(g.residual->createDataWithNodeCache());
  }
  return d;
}

std::unique_ptr<NodeData> OptimalControlProblem::createNodeDataSharingWorkspaces(
    const NodeData& other) const {
  if (other.cost_data.size() != costs_.size() || other.equality_data.size() != equalities_.size() ||
      other.inequality_data.size() != inequalities_.size() || !other.dynamics_data ||
      (pre_ != nullptr) != (other.cache != nullptr)) {
    throw std::invalid_argument(
        "OptimalControlProblem::createNodeDataSharingWorkspaces: workspaces of another problem");
  }
  auto d = createNodeBlocks();
  d->cache = other.cache;
  d->dynamics_data = other.dynamics_data;
  d->cost_data = other.cost_data;
  d->equality_data = other.equality_data;
  d->inequality_data = other.inequality_data;
  return d;
}

void OptimalControlProblem::evaluate(int k, ConstVecRef x, ConstVecRef u, NodeData& d) const {
  run(k, x, u, d, Pass::Values);
}

void OptimalControlProblem::linearize(int k, ConstVecRef x, ConstVecRef u, NodeData& d) const {
  run(k, x, u, d, Pass::Derivatives);
}

void OptimalControlProblem::linearizeCurvatureTerms(int k, ConstVecRef x, ConstVecRef u,
                                                    NodeData& d) const {
  run(k, x, u, d, Pass::Curvature);
}

bool OptimalControlProblem::hasCurvature() const {
  if (!stateSpace().isEuclidean() || !dynamics_->isLinear()) return true;
  for (const auto& c : costs_) {
    if (!c.term->hessianIsExact()) return true;
  }
  for (const auto& e : equalities_) {
    if (!e->isLinear()) return true;
  }
  for (const auto& g : inequalities_) {
    if (!g.residual->isLinear()) return true;
  }
  return false;
}

void OptimalControlProblem::run(int k, ConstVecRef x, ConstVecRef u_in, NodeData& d,
                                Pass pass) const {
  NodeContext ctx = context(k);
  ctx.cache = d.cache.get();
  d.context = ctx;
  const bool terminal = ctx.terminal;
  const bool derivatives = pass != Pass::Values;
  // Curvature pass: terms whose derivatives are constant are skipped (zero contribution).
  const bool curvature = pass == Pass::Curvature;
  const Eigen::Ref<const VectorXd> u = terminal ? Eigen::Ref<const VectorXd>(d.zero_input) : u_in;
  if (pre_ && d.cache) pre_->compute(ctx, x, u, derivatives, *d.cache);

  // Cost.
  d.cost = 0.0;
  if (derivatives) {
    d.lx.setZero();
    d.lu.setZero();
    d.Lxx.setZero();
    d.Luu.setZero();
    d.Lux.setZero();
  }
  const double scale = terminal ? 1.0 : dt_;
  for (std::size_t i = 0; i < costs_.size(); ++i) {
    const auto& c = costs_[i];
    if (!appliesTo(c.stage, terminal) || !c.term->active(ctx)) continue;
    if (curvature && c.term->hessianIsExact()) continue;
    CostData& cd = *d.cost_data[i];
    d.cost += scale * c.term->calc(ctx, x, u, cd);
    if (derivatives) c.term->calcDiff(ctx, x, u, cd, scale, d.lx, d.lu, d.Lxx, d.Luu, d.Lux);
  }

  // Dynamics.
  if (!terminal) {
    dynamics_->calc(ctx, x, u, *d.dynamics_data, d.xnext);
    if (curvature && dynamics_->isLinear() && stateSpace().isEuclidean()) {
      d.Fx.setZero();
      d.Fu.setZero();
    } else if (derivatives) {
      dynamics_->calcDiff(ctx, x, u, *d.dynamics_data, d.Fx, d.Fu);
    }
  }

  // Equalities (running nodes only), stacked in the order they were added.
  int ne = 0;
  if (!terminal) {
    for (std::size_t i = 0; i < equalities_.size(); ++i) {
      const Residual& r = *equalities_[i];
      ResidualData& rd = *d.equality_data[i];
      const int rows = r.rows(ctx);
      rd.rows = rows;
      if (rows == 0) continue;
      if (curvature && r.isLinear()) {
        d.Ex.middleRows(ne, rows).setZero();
        d.Eu.middleRows(ne, rows).setZero();
        ne += rows;
        continue;
      }
      r.calc(ctx, x, u, rd);
      d.e.segment(ne, rows) = rd.r.head(rows);
      if (derivatives) {
        r.calcDiffInto(ctx, x, u, rd, d.Ex.middleRows(ne, rows), d.Eu.middleRows(ne, rows));
      }
      ne += rows;
    }
  }
  d.ne = ne;

  // Inequalities.
  int ni = 0;
  for (std::size_t i = 0; i < inequalities_.size(); ++i) {
    const auto& entry = inequalities_[i];
    if (!appliesTo(entry.stage, terminal)) continue;
    ResidualData& rd = *d.inequality_data[i];
    const int rows = entry.residual->rows(ctx);
    rd.rows = rows;
    if (rows == 0) continue;
    d.soft.segment(ni, rows).setConstant(entry.options.soft);
    d.state_only.segment(ni, rows).setConstant(terminal || !entry.residual->dependsOnInput());
    d.relaxation.segment(ni, rows).setConstant(entry.options.relaxation);
    d.soft_weight.segment(ni, rows).setConstant(entry.options.weight);
    d.mirror.segment(ni, rows).setConstant(-1);
    const int m = entry.residual->mirroredRows(ctx);
    if (m > 0 && 2 * m <= rows) {
      for (int j = ni; j < ni + m; ++j) {
        d.mirror(j) = j + m;
        d.mirror(j + m) = j;
      }
    }
    if (curvature && entry.residual->isLinear()) {
      d.Gx.middleRows(ni, rows).setZero();
      d.Gu.middleRows(ni, rows).setZero();
      ni += rows;
      continue;
    }
    entry.residual->calc(ctx, x, u, rd);
    d.g.segment(ni, rows) = rd.r.head(rows);
    if (derivatives) {
      // Terminal and soft rows are state-only: their Gu rows are zero whatever Ru is.
      const bool no_input = terminal || entry.options.soft;
      entry.residual->calcDiffInto(
          ctx, x, u, rd, d.Gx.middleRows(ni, rows),
          no_input ? MatRef(rd.Ru.topRows(rows)) : MatRef(d.Gu.middleRows(ni, rows)));
      if (no_input) d.Gu.middleRows(ni, rows).setZero();
    }
    ni += rows;
  }
  d.ni = ni;
}

}  // namespace rollstep::ocp
