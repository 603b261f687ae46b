#include "fleetmap/relaxation/relaxed_layout.h"

#include <ceres/ceres.h>
#include <ceres/manifold.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <limits>
#include <memory>
#include <queue>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

using Matrix6 = Eigen::Matrix<double, 6, 6>;

// One metric edge's residual: the layout's a_T_b against the measured one, as the left
// perturbation (omega, v) in a's frame that takes the measurement to the layout's pose (se3.h),
// whitened: residual = S * (omega, v) with S^T S the edge's information.
class EdgeResidual {
 public:
  // REQUIRES: sqrt_information is upper triangular.
  EdgeResidual(const Se3& a_T_b, const Matrix6& sqrt_information)
      : q_ab_inverse_(Eigen::Quaterniond(a_T_b.rotation()).normalized().conjugate()),
        p_ab_(a_T_b.translation()),
        sqrt_information_(sqrt_information) {}

  template <typename T>
  bool operator()(const T* q_a_in, const T* p_a_in, const T* q_b_in, const T* p_b_in,
                  T* residual_out) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_a(q_a_in), q_b(q_b_in);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_a(p_a_in), p_b(p_b_in);
    const Eigen::Quaternion<T> q_a_inverse = q_a.conjugate();
    const Eigen::Quaternion<T> q_ab = q_a_inverse * q_b;
    const Eigen::Matrix<T, 3, 1> p_ab = q_a_inverse * (p_b - p_a);
    // layout a_T_b = exp(xi) * measured a_T_b: the rotation part from q_ab * q_measured^-1, the
    // translation what is left once that rotation has moved the measured translation.
    const Eigen::Quaternion<T> q_error = q_ab * q_ab_inverse_.template cast<T>();
    const Eigen::Matrix<T, 3, 1> rotation = T(2.0) * q_error.vec();
    const Eigen::Matrix<T, 3, 1> translation = p_ab - q_error * p_ab_.template cast<T>();
    const T xi[6] = {rotation[0],    rotation[1],    rotation[2],
                     translation[0], translation[1], translation[2]};
    // S is upper triangular (a Cholesky factor): multiplied by hand, in doubles where it can be,
    // rather than as a 6x6 matrix of derivatives.
    for (int row = 0; row < 6; ++row) {
      residual_out[row] = sqrt_information_(row, row) * xi[row];
      for (int column = row + 1; column < 6; ++column) {
        residual_out[row] += sqrt_information_(row, column) * xi[column];
      }
    }
    return true;
  }

 private:
  Eigen::Quaterniond q_ab_inverse_;
  Eigen::Vector3d p_ab_;
  Matrix6 sqrt_information_;
};

// S with S^T S = Σ^-1 for an edge's covariance, or the default standard deviations' when it has
// none or one that is not positive definite.
Matrix6 SqrtInformation(const Edge& edge, const RelaxationOptions& options) {
  if (edge.covariance) {
    const Eigen::LLT<Matrix6> covariance(*edge.covariance);
    if (covariance.info() == Eigen::Success) {
      const Matrix6 information = covariance.solve(Matrix6::Identity());
      const Eigen::LLT<Matrix6> root(0.5 * (information + information.transpose()));
      if (root.info() == Eigen::Success) return root.matrixU();
    }
  }
  Matrix6 s = Matrix6::Zero();
  s.diagonal().head<3>().setConstant(1.0 / options.default_sigma_rad);
  s.diagonal().tail<3>().setConstant(1.0 / options.default_sigma_m);
  return s;
}

// Where the solve starts: each component laid out from its reference along the chains that cross
// the fewest edges between outings, and among those the shortest in metres. The composed layout
// follows the fewest edges, whatever they are, so one wrong match between outings can place half
// a loop 40 m off, and a robust loss cannot bring back what starts that far from the truth; an
// outing's own odometry drifts, but only a little at a time.
std::vector<Se3> StartPoses(const GraphLayout& composed, std::span<const Edge* const> metric,
                            const std::vector<std::pair<std::size_t, std::size_t>>& ends) {
  const std::vector<LaidOutNode>& nodes = composed.nodes();
  struct Step {
    std::size_t to;
    const Edge* edge;
    bool forwards;
    bool across;
  };
  std::vector<std::vector<Step>> steps(nodes.size());
  for (std::size_t e = 0; e < metric.size(); ++e) {
    const auto [a, b] = ends[e];
    const bool across = nodes[a].outing != nodes[b].outing;
    steps[a].push_back({b, metric[e], true, across});
    steps[b].push_back({a, metric[e], false, across});
  }
  using Cost = std::pair<std::size_t, double>;  // (edges between outings, metres)
  const Cost unreached{std::numeric_limits<std::size_t>::max(), 0.0};
  std::vector<Cost> cost(nodes.size(), unreached);
  std::vector<Se3> poses(nodes.size(), Se3::Identity());
  using Entry = std::tuple<Cost, std::size_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  for (const std::size_t reference : composed.references()) {
    cost[reference] = {0, 0.0};
    queue.emplace(cost[reference], reference);
  }
  while (!queue.empty()) {
    const auto [at_cost, at] = queue.top();
    queue.pop();
    if (at_cost != cost[at]) continue;
    for (const Step& step : steps[at]) {
      const Cost next{at_cost.first + (step.across ? 1 : 0),
                      at_cost.second + step.edge->from_T_to.translation().norm()};
      if (!(next < cost[step.to])) continue;
      cost[step.to] = next;
      poses[step.to] = step.forwards ? poses[at] * step.edge->from_T_to
                                     : poses[at] * step.edge->from_T_to.inverse();
      queue.emplace(next, step.to);
    }
  }
  return poses;
}

std::string TooLargeToRelax(std::size_t nodes, std::size_t max_nodes) {
  return std::to_string(nodes) + " nodes, more than the " + std::to_string(max_nodes) +
         " relaxed here";
}

}  // namespace

GraphLayout RelaxLayout(const GraphLayout& composed, std::span<const Edge> edges,
                        const RelaxationOptions& options, RelaxationReport* report) {
  const auto start = std::chrono::steady_clock::now();
  const std::vector<LaidOutNode>& nodes = composed.nodes();
  RelaxationReport local;
  RelaxationReport& out = report ? *report : local;
  out = {};
  if (options.max_nodes > 0 && nodes.size() > options.max_nodes) {
    out.failure = TooLargeToRelax(nodes.size(), options.max_nodes);
    return composed;
  }

  std::vector<const Edge*> metric;
  for (const Edge& edge : edges) {
    if (edge.kind != EdgeKind::kMetric || edge.from == edge.to) continue;
    metric.push_back(&edge);
  }
  std::sort(metric.begin(), metric.end(),
            [](const Edge* a, const Edge* b) { return a->id < b->id; });

  std::vector<std::pair<std::size_t, std::size_t>> ends;
  ends.reserve(metric.size());
  for (const Edge* edge : metric) {
    const std::optional<std::size_t> a = composed.IndexOf(edge->from);
    const std::optional<std::size_t> b = composed.IndexOf(edge->to);
    if (!a || !b) {
      throw Error(ErrorCode::kIntegrity, "relaxed layout: metric edge " + edge->id.ToString() +
                                             " ends outside the layout");
    }
    ends.emplace_back(*a, *b);
  }

  // Each node's pose as Ceres' parameter blocks: a quaternion (x, y, z, w, as Eigen stores it)
  // and a position.
  const std::vector<Se3> start_poses = StartPoses(composed, metric, ends);
  std::vector<Eigen::Quaterniond> rotation(nodes.size());
  std::vector<Eigen::Vector3d> position(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    rotation[i] = Eigen::Quaterniond(start_poses[i].rotation()).normalized();
    position[i] = start_poses[i].translation();
  }

  ceres::Problem::Options problem_options;
  // The problem outlives nothing it is given: the manifold and the loss are owned here.
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::EigenQuaternionManifold quaternion_manifold;
  ceres::LossFunctionWrapper between_outings(
      new ceres::CauchyLoss(options.between_outings_loss_scale), ceres::TAKE_OWNERSHIP);
  std::vector<char> solved(nodes.size(), 0);
  std::vector<double> across_at_start;  // whitened residual norms of the edges between outings
  for (std::size_t e = 0; e < metric.size(); ++e) {
    const Edge* edge = metric[e];
    const auto [a, b] = ends[e];
    const bool across = nodes[a].outing != nodes[b].outing;
    auto* residual = new EdgeResidual(edge->from_T_to, SqrtInformation(*edge, options));
    if (across) {
      Eigen::Matrix<double, 6, 1> r;
      (*residual)(rotation[a].coeffs().data(), position[a].data(), rotation[b].coeffs().data(),
                  position[b].data(), r.data());
      across_at_start.push_back(r.norm());
    }
    auto* cost = new ceres::AutoDiffCostFunction<EdgeResidual, 6, 4, 3, 4, 3>(residual);
    problem.AddResidualBlock(cost, across ? &between_outings : nullptr, rotation[a].coeffs().data(),
                             position[a].data(), rotation[b].coeffs().data(), position[b].data());
    for (const std::size_t end : {a, b}) {
      if (solved[end]) continue;
      solved[end] = 1;
      problem.SetManifold(rotation[end].coeffs().data(), &quaternion_manifold);
      ++out.nodes;
    }
    ++out.edges;
    if (across) ++out.edges_between_outings;
  }
  // Each component stays in its reference's frame.
  for (const std::size_t reference : composed.references()) {
    if (!solved[reference]) continue;
    problem.SetParameterBlockConstant(rotation[reference].coeffs().data());
    problem.SetParameterBlockConstant(position[reference].data());
  }

  if (out.edges > 0) {
    ceres::Solver::Options solver;
    solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    solver.num_threads = 1;  // the same poses, to the bit, every time
    solver.max_num_iterations = options.max_iterations;
    solver.logging_type = ceres::SILENT;
    solver.function_tolerance = options.function_tolerance;
    solver.minimizer_progress_to_stdout = false;
    problem.Evaluate(ceres::Problem::EvaluateOptions(), &out.initial_cost, nullptr, nullptr,
                     nullptr);
    // Two solves. At the start an outing's drift leaves its true loop closures many standard
    // deviations off, where the robust loss would ignore them and the loop stay open. So the first
    // solve widens the loss to the median of those edges' residuals: the typical closure counts,
    // one far beyond it (a wrong match) still does not. The second, from there, uses the loss as
    // set.
    double widened = options.between_outings_loss_scale;
    if (!across_at_start.empty()) {
      std::nth_element(
          across_at_start.begin(),
          across_at_start.begin() + static_cast<std::ptrdiff_t>(across_at_start.size() / 2),
          across_at_start.end());
      widened = std::max(widened, across_at_start[across_at_start.size() / 2]);
    }
    std::vector<double> scales = {options.between_outings_loss_scale};
    if (widened > scales.front()) scales.insert(scales.begin(), widened);
    for (const double scale : scales) {
      between_outings.Reset(new ceres::CauchyLoss(scale), ceres::TAKE_OWNERSHIP);
      ceres::Solver::Summary summary;
      ceres::Solve(solver, &problem, &summary);
      if (!summary.IsSolutionUsable()) {
        // A picture must still be drawn: the composed layout, said so.
        out.failure = summary.message;
        out.seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return composed;
      }
      out.iterations += static_cast<int>(summary.iterations.size()) - 1;
      out.final_cost = summary.final_cost;
      out.converged = summary.termination_type == ceres::CONVERGENCE;
    }
  }

  std::vector<Se3> poses(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (!solved[i]) {
      poses[i] = nodes[i].layout_T_node;  // a node of no metric edge: a component's reference
      continue;
    }
    poses[i] = Se3FromTranslationQuaternion(position[i], rotation[i].normalized());
  }
  // The references were held: their poses are the identity exactly, as the layout requires.
  for (const std::size_t reference : composed.references()) poses[reference] = Se3::Identity();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return composed.WithPoses(std::move(poses));
}

std::string_view LayoutName(LayoutKind kind) {
  return kind == LayoutKind::kRelaxed ? "relaxed" : "composed";
}

LayoutKind ParseLayoutKind(std::string_view text) {
  if (text == "relaxed") return LayoutKind::kRelaxed;
  if (text == "composed") return LayoutKind::kComposed;
  throw Error(ErrorCode::kInvalidArgument,
              "unknown layout '" + std::string(text) + "': expected relaxed or composed");
}

std::string DescribeLayout(LayoutKind kind) {
  return kind == LayoutKind::kRelaxed
             ? "layout relaxed: node poses from a pose-graph relaxation of the metric edges, "
               "for display only (the map stores relative poses)"
             : "layout composed: node poses composed along metric edges breadth first from "
               "each component's earliest node";
}

GraphLayout LayOutGraph(const std::vector<Node>& nodes, const std::vector<Edge>& edges,
                        LayoutKind kind, RelaxationReport* report,
                        const RelaxationOptions& options) {
  GraphLayout composed = GraphLayout::Compute(nodes, edges);
  if (kind == LayoutKind::kComposed) return composed;
  if (options.max_nodes > 0 && composed.nodes().size() > options.max_nodes) {
    // Not relaxed: the composed layout itself, not a copy of it (a large map's picture is drawn
    // beside a download plan of the same map; two layouts of it would be held at once).
    RelaxationReport skipped;
    skipped.failure = TooLargeToRelax(composed.nodes().size(), options.max_nodes);
    if (report) *report = std::move(skipped);
    return composed;
  }
  return RelaxLayout(composed, edges, options, report);
}

}  // namespace fleetmap
