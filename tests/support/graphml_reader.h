// A GraphML reader for the tests, written from the GraphML primer and schema on top of
// xml_reader.h: the root <graphml> in GraphML's namespace holding <key>s (id, for, attr.name,
// attr.type) and one <graph> with an edgedefault; <node>s and <edge>s with <data> children.
// It checks what a graph tool relies on: every key declared once with a known type and a unique
// attr.name, every <data> naming a declared key of its domain with a value of the key's type,
// node ids unique, every edge's source and target a node. Anything else throws
// std::runtime_error saying what.
#pragma once

#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "text_fields.h"
#include "xml_reader.h"

namespace fleetmap::testing {

struct GraphMlKey {
  std::string domain;  // `for`
  std::string name;    // attr.name
  std::string type;    // attr.type
};

struct GraphMlItem {
  std::string id;
  std::string source, target;               // edges only
  std::map<std::string, std::string> data;  // by attr.name

  const std::string& Data(const std::string& name) const {
    const auto found = data.find(name);
    if (found == data.end()) throw std::runtime_error("graphml: " + id + " has no " + name);
    return found->second;
  }
  double Number(const std::string& name) const { return WholeNumber(Data(name), id); }
};

struct GraphMlGraph {
  std::string edgedefault;
  std::string description;
  std::map<std::string, GraphMlKey> keys;  // by id
  std::vector<GraphMlItem> nodes, edges;
};

inline GraphMlGraph ReadGraphMl(const std::string& text) {
  const XmlElement root = XmlReader::Parse(text);
  const auto fail = [](const std::string& what) { throw std::runtime_error("graphml: " + what); };
  if (root.name != "graphml") fail("the root element is <" + root.name + ">");
  if (root.Attribute("xmlns") != "http://graphml.graphdrawing.org/xmlns") {
    fail("not in GraphML's namespace");
  }
  GraphMlGraph graph;
  std::set<std::string> names;
  const XmlElement* graph_element = nullptr;
  for (const XmlElement& child : root.children) {
    if (child.name == "key") {
      if (graph_element != nullptr) fail("a <key> after the <graph>");
      GraphMlKey key{child.Attribute("for"), child.Attribute("attr.name"),
                     child.Attribute("attr.type")};
      static const std::set<std::string> kDomains = {"graph", "node", "edge", "all"};
      static const std::set<std::string> kTypes = {"boolean", "int",    "long",
                                                   "float",   "double", "string"};
      if (!kDomains.contains(key.domain)) fail("key for '" + key.domain + "'");
      if (!kTypes.contains(key.type)) fail("key of type '" + key.type + "'");
      if (!names.insert(key.name).second) fail("attr.name " + key.name + " declared twice");
      if (!graph.keys.emplace(child.Attribute("id"), key).second) fail("key id given twice");
    } else if (child.name == "graph") {
      if (graph_element != nullptr) fail("more than one <graph>");
      graph_element = &child;
    } else if (child.name != "desc" && child.name != "data") {
      fail("<" + child.name + "> in <graphml>");
    }
  }
  if (graph_element == nullptr) fail("no <graph>");
  graph.edgedefault = graph_element->Attribute("edgedefault");
  if (graph.edgedefault != "directed" && graph.edgedefault != "undirected") {
    fail("edgedefault '" + graph.edgedefault + "'");
  }

  const auto read_data = [&](const XmlElement& element, const std::string& domain,
                             GraphMlItem& item) {
    for (const XmlElement& data : element.children) {
      if (data.name != "data") fail("<" + data.name + "> in <" + domain + ">");
      const auto key = graph.keys.find(data.Attribute("key"));
      if (key == graph.keys.end()) fail("data of the undeclared key " + data.Attribute("key"));
      if (key->second.domain != domain && key->second.domain != "all") {
        fail("a " + key->second.domain + " key on a " + domain);
      }
      const std::string& type = key->second.type;
      if (type == "int" || type == "long") WholeInteger(data.text, "graphml " + item.id);
      if (type == "double" || type == "float") WholeNumber(data.text, "graphml " + item.id);
      if (!item.data.emplace(key->second.name, data.text).second) {
        fail(key->second.name + " given twice in " + item.id);
      }
    }
  };
  std::set<std::string> node_ids;
  bool description_allowed = true;
  for (const XmlElement& child : graph_element->children) {
    if (child.name == "desc") {
      if (!description_allowed) fail("<desc> is not the first child of <graph>");
      graph.description = child.text;
    } else if (child.name == "node") {
      GraphMlItem node;
      node.id = child.Attribute("id");
      if (!node_ids.insert(node.id).second) fail("node id " + node.id + " given twice");
      read_data(child, "node", node);
      graph.nodes.push_back(node);
    } else if (child.name == "edge") {
      GraphMlItem edge;
      edge.id = child.attributes.contains("id") ? child.Attribute("id") : "";
      edge.source = child.Attribute("source");
      edge.target = child.Attribute("target");
      read_data(child, "edge", edge);
      graph.edges.push_back(edge);
    } else if (child.name != "data") {
      fail("<" + child.name + "> in <graph>");
    }
    description_allowed = false;
  }
  for (const GraphMlItem& edge : graph.edges) {
    if (!node_ids.contains(edge.source) || !node_ids.contains(edge.target)) {
      fail("edge " + edge.id + " between " + edge.source + " and " + edge.target +
           ", which are not both nodes");
    }
  }
  return graph;
}

}  // namespace fleetmap::testing
