// A PLY reader written for the tests from the format's description, not from the writer: the
// header (magic "ply", a format line, comment and obj_info lines, elements each with a count and
// properties, scalar or list, "end_header"), then the body in ascii or binary_little_endian,
// element by element. Anything else, a body too short or bytes left over, throws
// std::runtime_error saying what.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace fleetmap::testing {

struct PlyProperty {
  std::string type;  // the scalar type as written; for a list, its item type
  std::string name;
  bool is_list = false;
  std::string count_type;  // lists only
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
  // One row per instance: each property's values (one for a scalar, the items for a list).
  std::vector<std::vector<std::vector<double>>> rows;

  std::size_t PropertyIndex(const std::string& property) const {
    for (std::size_t i = 0; i < properties.size(); ++i) {
      if (properties[i].name == property) return i;
    }
    throw std::runtime_error("ply: element " + name + " has no property " + property);
  }
  double Scalar(std::size_t row, const std::string& property) const {
    return rows.at(row).at(PropertyIndex(property)).at(0);
  }
};

struct PlyFile {
  std::string format;  // ascii, binary_little_endian or binary_big_endian
  std::string version;
  std::vector<std::string> comments;
  std::vector<PlyElement> elements;

  const PlyElement& Element(const std::string& name) const {
    for (const PlyElement& element : elements) {
      if (element.name == name) return element;
    }
    throw std::runtime_error("ply: no element " + name);
  }
};

namespace ply_detail {

// Bytes of each scalar type, under both the original names and the sized ones.
inline std::size_t ScalarBytes(const std::string& type) {
  static const std::map<std::string, std::size_t> kBytes = {
      {"char", 1},  {"uchar", 1},  {"short", 2},   {"ushort", 2}, {"int", 4},   {"uint", 4},
      {"float", 4}, {"double", 8}, {"int8", 1},    {"uint8", 1},  {"int16", 2}, {"uint16", 2},
      {"int32", 4}, {"uint32", 4}, {"float32", 4}, {"float64", 8}};
  const auto found = kBytes.find(type);
  if (found == kBytes.end()) throw std::runtime_error("ply: unknown scalar type '" + type + "'");
  return found->second;
}

inline double DecodeLittleEndian(const std::string& type, const unsigned char* bytes) {
  std::uint64_t bits = 0;
  const std::size_t size = ScalarBytes(type);
  for (std::size_t i = 0; i < size; ++i) bits |= std::uint64_t{bytes[i]} << (8 * i);
  if (type == "float" || type == "float32") {
    return std::bit_cast<float>(static_cast<std::uint32_t>(bits));
  }
  if (type == "double" || type == "float64") return std::bit_cast<double>(bits);
  const bool is_signed = type == "char" || type == "short" || type == "int" || type == "int8" ||
                         type == "int16" || type == "int32";
  if (is_signed && size < 8 && (bits >> (8 * size - 1)) != 0) {
    bits |= ~std::uint64_t{0} << (8 * size);  // sign-extend
  }
  return is_signed ? static_cast<double>(static_cast<std::int64_t>(bits))
                   : static_cast<double>(bits);
}

}  // namespace ply_detail

inline PlyFile ReadPly(const std::string& bytes) {
  PlyFile file;
  std::size_t at = 0;
  const auto next_line = [&]() {
    const std::size_t end = bytes.find('\n', at);
    if (end == std::string::npos) throw std::runtime_error("ply: header ends without end_header");
    std::string line = bytes.substr(at, end - at);
    at = end + 1;
    return line;
  };
  if (next_line() != "ply") throw std::runtime_error("ply: the first line is not 'ply'");
  bool header_done = false;
  while (!header_done) {
    const std::string line = next_line();
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "format") {
      if (!file.format.empty()) throw std::runtime_error("ply: two format lines");
      words >> file.format >> file.version;
      if (file.format != "ascii" && file.format != "binary_little_endian" &&
          file.format != "binary_big_endian") {
        throw std::runtime_error("ply: unknown format '" + file.format + "'");
      }
      if (file.version != "1.0") throw std::runtime_error("ply: version " + file.version);
    } else if (keyword == "comment" || keyword == "obj_info") {
      if (keyword == "comment") file.comments.push_back(line.size() > 8 ? line.substr(8) : "");
    } else if (keyword == "element") {
      PlyElement element;
      long long count = -1;
      words >> element.name >> count;
      if (element.name.empty() || count < 0) {
        throw std::runtime_error("ply: bad element line '" + line + "'");
      }
      element.count = static_cast<std::size_t>(count);
      file.elements.push_back(element);
    } else if (keyword == "property") {
      if (file.elements.empty()) throw std::runtime_error("ply: property before any element");
      PlyProperty property;
      words >> property.type;
      if (property.type == "list") {
        property.is_list = true;
        words >> property.count_type >> property.type;
        ply_detail::ScalarBytes(property.count_type);
      }
      ply_detail::ScalarBytes(property.type);
      words >> property.name;
      if (property.name.empty()) throw std::runtime_error("ply: property without a name");
      file.elements.back().properties.push_back(property);
    } else if (keyword == "end_header") {
      header_done = true;
    } else {
      throw std::runtime_error("ply: unknown header line '" + line + "'");
    }
    std::string extra;
    if (keyword != "comment" && keyword != "obj_info" && (words >> extra)) {
      throw std::runtime_error("ply: extra words in header line '" + line + "'");
    }
  }
  if (file.format.empty()) throw std::runtime_error("ply: no format line");

  if (file.format == "ascii") {
    std::istringstream body(bytes.substr(at));
    for (PlyElement& element : file.elements) {
      for (std::size_t row = 0; row < element.count; ++row) {
        std::vector<std::vector<double>> values;
        for (const PlyProperty& property : element.properties) {
          double count = 1;
          if (property.is_list && !(body >> count)) throw std::runtime_error("ply: body too short");
          std::vector<double> items(static_cast<std::size_t>(count));
          for (double& item : items) {
            if (!(body >> item)) throw std::runtime_error("ply: body too short");
          }
          values.push_back(items);
        }
        element.rows.push_back(values);
      }
    }
    std::string extra;
    if (body >> extra) throw std::runtime_error("ply: data after the last element");
    return file;
  }
  if (file.format != "binary_little_endian") {
    throw std::runtime_error("ply: this reader reads ascii and binary_little_endian only");
  }
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const auto take = [&](const std::string& type) {
    const std::size_t size = ply_detail::ScalarBytes(type);
    if (at + size > bytes.size()) throw std::runtime_error("ply: body too short");
    const double value = ply_detail::DecodeLittleEndian(type, data + at);
    at += size;
    return value;
  };
  for (PlyElement& element : file.elements) {
    for (std::size_t row = 0; row < element.count; ++row) {
      std::vector<std::vector<double>> values;
      for (const PlyProperty& property : element.properties) {
        const std::size_t count =
            property.is_list ? static_cast<std::size_t>(take(property.count_type)) : 1;
        std::vector<double> items;
        for (std::size_t i = 0; i < count; ++i) items.push_back(take(property.type));
        values.push_back(items);
      }
      element.rows.push_back(values);
    }
  }
  if (at != bytes.size()) {
    throw std::runtime_error("ply: " + std::to_string(bytes.size() - at) +
                             " bytes after the last element");
  }
  return file;
}

}  // namespace fleetmap::testing
