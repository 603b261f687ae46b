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

// Says so in `out` and returns true when `layout` has more nodes than options.max_nodes allows.
bool TooLargeToRelax(const GraphLayout& layout, const RelaxationOptions& options,
                     RelaxationReport& out) {
  if (options.max_nodes == 0 || layout.nodes().size() <= options.max_nodes) return false;
  out.failure = std::to_string(layout.nodes().size()) + " nodes, more than the " +
                std::to_string(options.max_nodes) + " relaxed here";
  return true;
}

// The metric edges between two different nodes, by UUID, and their ends' numbers in the layout.
struct OrderedMetricEdges {
  std::vector<const Edge*> edges;
  std::vector<std::pair<std::size_t, std::size_t>> ends;
};

OrderedMetricEdges MetricEdgesOf(const GraphLayout& layout, std::span<const Edge> edges) {
  OrderedMetricEdges metric;
  for (const Edge& edge : edges) {
    if (edge.kind == EdgeKind::kMetric && edge.from != edge.to) metric.edges.push_back(&edge);
  }
  std::sort(metric.edges.begin(), metric.edges.end(),
            [](const Edge* a, const Edge* b) { return a->id < b->id; });
  metric.ends.reserve(metric.edges.size());
  for (const Edge* edge : metric.edges) {
    const std::optional<std::size_t> a = layout.IndexOf(edge->from);
    const std::optional<std::size_t> b = layout.IndexOf(edge->to);
    if (!a || !b) {
      throw Error(ErrorCode::kIntegrity, "relaxed layout: metric edge " + edge->id.ToString() +
                                             " ends outside the layout");
    }
    metric.ends.emplace_back(*a, *b);
  }
  return metric;
}

// The least-squares problem over the layout's poses: each node's pose as Ceres' parameter blocks,
// a quaternion (x, y, z, w, as Eigen stores it) and a position; a residual per metric edge.
class PoseGraphProblem {
 public:
  PoseGraphProblem(const GraphLayout& composed, const OrderedMetricEdges& metric,
                   const RelaxationOptions& options, RelaxationReport& out)
      : composed_(composed),
        options_(options),
        problem_(ProblemOptions()),
        between_outings_(new ceres::CauchyLoss(options.between_outings_loss_scale),
                         ceres::TAKE_OWNERSHIP) {
    const std::vector<LaidOutNode>& nodes = composed.nodes();
    const std::vector<Se3> start_poses = StartPoses(composed, metric.edges, metric.ends);
    rotation_.resize(nodes.size());
    position_.resize(nodes.size());
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      rotation_[i] = Eigen::Quaterniond(start_poses[i].rotation()).normalized();
      position_[i] = start_poses[i].translation();
    }
    solved_.assign(nodes.size(), 0);
    for (std::size_t e = 0; e < metric.edges.size(); ++e) {
      AddEdge(*metric.edges[e], metric.ends[e].first, metric.ends[e].second, out);
    }
    // Each component stays in its reference's frame.
    for (const std::size_t reference : composed.references()) {
      if (!solved_[reference]) continue;
      problem_.SetParameterBlockConstant(rotation_[reference].coeffs().data());
      problem_.SetParameterBlockConstant(position_[reference].data());
    }
  }

  // Solves; false (and out.failure) when Ceres gives nothing usable.
  bool Solve(RelaxationReport& out) {
    if (out.edges == 0) return true;
    ceres::Solver::Options solver;
    solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    solver.num_threads = 1;  // the same poses, to the bit, every time
    solver.max_num_iterations = options_.max_iterations;
    solver.logging_type = ceres::SILENT;
    solver.function_tolerance = options_.function_tolerance;
    solver.minimizer_progress_to_stdout = false;
    problem_.Evaluate(ceres::Problem::EvaluateOptions(), &out.initial_cost, nullptr, nullptr,
                      nullptr);
    for (const double scale : LossScales()) {
      between_outings_.Reset(new ceres::CauchyLoss(scale), ceres::TAKE_OWNERSHIP);
      ceres::Solver::Summary summary;
      ceres::Solve(solver, &problem_, &summary);
      if (!summary.IsSolutionUsable()) {
        out.failure = summary.message;
        return false;
      }
      out.iterations += static_cast<int>(summary.iterations.size()) - 1;
      out.final_cost = summary.final_cost;
      out.converged = summary.termination_type == ceres::CONVERGENCE;
    }
    return true;
  }

  // Every node's pose: solved, or as composed for a node of no metric edge (a component's
  // reference); the references exactly the identity, as the layout requires (they were held).
  std::vector<Se3> Poses() const {
    const std::vector<LaidOutNode>& nodes = composed_.nodes();
    std::vector<Se3> poses(nodes.size());
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      poses[i] = solved_[i] ? Se3FromTranslationQuaternion(position_[i], rotation_[i].normalized())
                            : nodes[i].layout_T_node;
    }
    for (const std::size_t reference : composed_.references()) poses[reference] = Se3::Identity();
    return poses;
  }

 private:
  static ceres::Problem::Options ProblemOptions() {
    ceres::Problem::Options options;
    // The problem outlives nothing it is given: the manifold and the loss are owned here.
    options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    return options;
  }

  void AddEdge(const Edge& edge, std::size_t a, std::size_t b, RelaxationReport& out) {
    const bool across = composed_.nodes()[a].outing != composed_.nodes()[b].outing;
    auto* residual = new EdgeResidual(edge.from_T_to, SqrtInformation(edge, options_));
    if (across) {
      Eigen::Matrix<double, 6, 1> r;
      (*residual)(rotation_[a].coeffs().data(), position_[a].data(), rotation_[b].coeffs().data(),
                  position_[b].data(), r.data());
      across_at_start_.push_back(r.norm());
    }
    auto* cost = new ceres::AutoDiffCostFunction<EdgeResidual, 6, 4, 3, 4, 3>(residual);
    problem_.AddResidualBlock(cost, across ? &between_outings_ : nullptr,
                              rotation_[a].coeffs().data(), position_[a].data(),
                              rotation_[b].coeffs().data(), position_[b].data());
    for (const std::size_t end : {a, b}) {
      if (solved_[end]) continue;
      solved_[end] = 1;
      problem_.SetManifold(rotation_[end].coeffs().data(), &quaternion_manifold_);
      ++out.nodes;
    }
    ++out.edges;
    if (across) ++out.edges_between_outings;
  }

  // Two solves. At the start an outing's drift leaves its true loop closures many standard
  // deviations off, where the robust loss would ignore them and the loop stay open. So the first
  // solve widens the loss to the median of those edges' residuals: the typical closure counts,
  // one far beyond it (a wrong match) still does not. The second, from there, uses the loss as
  // set. One solve when the median is within it.
  std::vector<double> LossScales() {
    double widened = options_.between_outings_loss_scale;
    if (!across_at_start_.empty()) {
      const auto middle =
          across_at_start_.begin() + static_cast<std::ptrdiff_t>(across_at_start_.size() / 2);
      std::nth_element(across_at_start_.begin(), middle, across_at_start_.end());
      widened = std::max(widened, *middle);
    }
    std::vector<double> scales = {options_.between_outings_loss_scale};
    if (widened > scales.front()) scales.insert(scales.begin(), widened);
    return scales;
  }

  const GraphLayout& composed_;
  const RelaxationOptions& options_;
  std::vector<Eigen::Quaterniond> rotation_;
  std::vector<Eigen::Vector3d> position_;
  std::vector<char> solved_;             // by node: has a metric edge, so is solved for
  std::vector<double> across_at_start_;  // whitened residual norms of the edges between outings
  ceres::Problem problem_;
  ceres::EigenQuaternionManifold quaternion_manifold_;
  ceres::LossFunctionWrapper between_outings_;
};

}  // namespace

GraphLayout RelaxLayout(const GraphLayout& composed, std::span<const Edge> edges,
                        const RelaxationOptions& options, RelaxationReport* report) {
  const auto start = std::chrono::steady_clock::now();
  RelaxationReport local;
  RelaxationReport& out = report ? *report : local;
  out = {};
  if (TooLargeToRelax(composed, options, out)) return composed;
  PoseGraphProblem problem(composed, MetricEdgesOf(composed, edges), options, out);
  const bool solved = problem.Solve(out);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // A picture must still be drawn: when the solve fails, the composed layout, said so.
  if (!solved) return composed;
  return composed.WithPoses(problem.Poses());
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
  // Not relaxed: the composed layout itself, not a copy of it (a large map's picture is drawn
  // beside a download plan of the same map; two layouts of it would be held at once).
  RelaxationReport skipped;
  if (TooLargeToRelax(composed, options, skipped)) {
    if (report) *report = std::move(skipped);
    return composed;
  }
  return RelaxLayout(composed, edges, options, report);
}

}  // namespace fleetmap
