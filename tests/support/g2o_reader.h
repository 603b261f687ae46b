// A reader of g2o's 3-D pose-graph text, written for the tests from the format's description:
//   VERTEX_SE3:QUAT id x y z qx qy qz qw
//   EDGE_SE3:QUAT id1 id2 x y z qx qy qz qw  + 21 numbers, the upper triangle of the 6x6
//                                              information matrix row by row
//   FIX id...
// Lines starting with '#' and empty lines are skipped. An unknown tag, a wrong number of fields,
// a number that does not parse, a vertex given twice or an edge or FIX naming no vertex throws
// std::runtime_error quoting the line.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "text_fields.h"

namespace fleetmap::testing {

struct G2oPose {
  Eigen::Vector3d translation;
  Eigen::Quaterniond rotation;  // as written: x y z w, not normalised here
};

struct G2oEdge {
  long long from = 0, to = 0;
  G2oPose measurement;
  Eigen::Matrix<double, 6, 6> information;  // rebuilt symmetric from the upper triangle
};

struct G2oGraph {
  std::map<long long, G2oPose> vertices;
  std::vector<long long> vertex_order;  // ids in the order the file gives them
  std::vector<G2oEdge> edges;
  std::set<long long> fixed;
};

inline G2oGraph ReadG2o(const std::string& text) {
  G2oGraph graph;
  std::istringstream lines(text);
  std::string line;
  const auto number = [&line](const std::string& field) {
    return WholeNumber(field, "g2o line '" + line + "'");
  };
  const auto id = [&line](const std::string& field) {
    return WholeInteger(field, "g2o line '" + line + "'");
  };
  const auto pose = [&](const std::vector<std::string>& fields, std::size_t first) {
    G2oPose p;
    p.translation = {number(fields[first]), number(fields[first + 1]), number(fields[first + 2])};
    p.rotation = Eigen::Quaterniond(number(fields[first + 6]), number(fields[first + 3]),
                                    number(fields[first + 4]), number(fields[first + 5]));
    return p;
  };
  while (std::getline(lines, line)) {
    const std::vector<std::string> fields = SplitFields(line);
    if (fields.empty() || fields[0][0] == '#') continue;
    const std::string& tag = fields[0];
    if (tag == "VERTEX_SE3:QUAT") {
      if (fields.size() != 9) throw std::runtime_error("g2o: 9 fields wanted: '" + line + "'");
      const long long vertex = id(fields[1]);
      if (!graph.vertices.emplace(vertex, pose(fields, 2)).second) {
        throw std::runtime_error("g2o: vertex given twice: '" + line + "'");
      }
      graph.vertex_order.push_back(vertex);
    } else if (tag == "EDGE_SE3:QUAT") {
      if (fields.size() != 3 + 7 + 21) {
        throw std::runtime_error("g2o: 31 fields wanted: '" + line + "'");
      }
      G2oEdge edge;
      edge.from = id(fields[1]);
      edge.to = id(fields[2]);
      if (!graph.vertices.contains(edge.from) || !graph.vertices.contains(edge.to)) {
        throw std::runtime_error("g2o: edge before or without its vertices: '" + line + "'");
      }
      edge.measurement = pose(fields, 3);
      std::size_t field = 10;
      for (int row = 0; row < 6; ++row) {
        for (int column = row; column < 6; ++column) {
          edge.information(row, column) = edge.information(column, row) = number(fields[field++]);
        }
      }
      graph.edges.push_back(edge);
    } else if (tag == "FIX") {
      if (fields.size() < 2) throw std::runtime_error("g2o: FIX without ids: '" + line + "'");
      for (std::size_t i = 1; i < fields.size(); ++i) {
        const long long vertex = id(fields[i]);
        if (!graph.vertices.contains(vertex)) {
          throw std::runtime_error("g2o: FIX of an unknown vertex: '" + line + "'");
        }
        graph.fixed.insert(vertex);
      }
    } else {
      throw std::runtime_error("g2o: unknown tag '" + tag + "'");
    }
  }
  return graph;
}

}  // namespace fleetmap::testing
