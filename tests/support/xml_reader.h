// A small XML 1.0 reader for the tests, written from the XML specification: one root element;
// elements with attributes (quoted with " or ', each name once), character data with the five
// predefined entities and character references, self-closing tags, comments, processing
// instructions (the XML declaration among them). What it does not know (DOCTYPE, CDATA, other
// entities) and anything not well-formed (a tag closed by another name, a bare '&' or '<', text
// outside the root) throws std::runtime_error saying where.
#pragma once

#include <cctype>
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace fleetmap::testing {

struct XmlElement {
  std::string name;
  std::map<std::string, std::string> attributes;
  std::vector<XmlElement> children;
  std::string text;  // the character data directly inside, entities decoded

  const std::string& Attribute(const std::string& attribute) const {
    const auto found = attributes.find(attribute);
    if (found == attributes.end()) {
      throw std::runtime_error("xml: <" + name + "> has no attribute " + attribute);
    }
    return found->second;
  }
};

class XmlReader {
 public:
  static XmlElement Parse(const std::string& text) {
    XmlReader reader(text);
    reader.SkipMisc();
    if (!reader.LookingAt("<")) reader.Fail("no root element");
    XmlElement root = reader.ParseElement();
    reader.SkipMisc();
    if (reader.at_ != text.size()) reader.Fail("content after the root element");
    return root;
  }

 private:
  explicit XmlReader(const std::string& text) : text_(text) {}

  [[noreturn]] void Fail(const std::string& what) const {
    throw std::runtime_error("xml: " + what + " at byte " + std::to_string(at_));
  }
  bool LookingAt(const std::string& s) const { return text_.compare(at_, s.size(), s) == 0; }
  void Expect(const std::string& s) {
    if (!LookingAt(s)) Fail("expected '" + s + "'");
    at_ += s.size();
  }
  void SkipSpace() {
    while (at_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[at_]))) ++at_;
  }
  void SkipPast(const std::string& end) {
    const std::size_t found = text_.find(end, at_);
    if (found == std::string::npos) Fail("unterminated, expected '" + end + "'");
    at_ = found + end.size();
  }
  // Whitespace, comments and processing instructions, outside or between elements.
  void SkipMisc() {
    for (;;) {
      SkipSpace();
      if (LookingAt("<!--")) {
        SkipPast("-->");
      } else if (LookingAt("<?")) {
        SkipPast("?>");
      } else {
        return;
      }
    }
  }
  static bool NameStart(char c) {
    return std::isalpha(static_cast<unsigned char>(c)) || c == '_' || c == ':';
  }
  static bool NameChar(char c) {
    return NameStart(c) || std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == '.';
  }
  std::string ParseName() {
    if (at_ >= text_.size() || !NameStart(text_[at_])) Fail("expected a name");
    const std::size_t start = at_;
    while (at_ < text_.size() && NameChar(text_[at_])) ++at_;
    return text_.substr(start, at_ - start);
  }
  // Character data up to `stop` (not consumed), with references decoded.
  std::string ParseCharacterData(char stop) {
    std::string out;
    while (at_ < text_.size() && text_[at_] != stop) {
      const char c = text_[at_];
      if (c == '<') Fail("'<' in an attribute value");
      if (c != '&') {
        out += c;
        ++at_;
        continue;
      }
      const std::size_t end = text_.find(';', at_);
      if (end == std::string::npos) Fail("'&' without ';'");
      const std::string entity = text_.substr(at_ + 1, end - at_ - 1);
      static const std::map<std::string, char> kPredefined = {
          {"amp", '&'}, {"lt", '<'}, {"gt", '>'}, {"quot", '"'}, {"apos", '\''}};
      if (const auto found = kPredefined.find(entity); found != kPredefined.end()) {
        out += found->second;
      } else if (entity.size() > 1 && entity[0] == '#') {
        const bool hex = entity[1] == 'x';
        std::uint32_t code = 0;
        try {
          code = static_cast<std::uint32_t>(
              std::stoul(entity.substr(hex ? 2 : 1), nullptr, hex ? 16 : 10));
        } catch (const std::exception&) {
          Fail("bad character reference &" + entity + ";");
        }
        if (code >= 0x80) Fail("this reader decodes ASCII character references only");
        if (code < 0x20 && code != '\t' && code != '\n' && code != '\r') {
          Fail("a reference to a character XML does not allow");
        }
        out += static_cast<char>(code);
      } else {
        Fail("unknown entity &" + entity + ";");
      }
      at_ = end + 1;
    }
    return out;
  }
  XmlElement ParseElement() {
    Expect("<");
    XmlElement element;
    element.name = ParseName();
    for (;;) {
      const std::size_t before = at_;
      SkipSpace();
      if (LookingAt("/>")) {
        at_ += 2;
        return element;
      }
      if (LookingAt(">")) {
        ++at_;
        break;
      }
      if (at_ == before) Fail("expected space between attributes");
      const std::string attribute = ParseName();
      SkipSpace();
      Expect("=");
      SkipSpace();
      if (at_ >= text_.size() || (text_[at_] != '"' && text_[at_] != '\'')) {
        Fail("attribute " + attribute + " is not quoted");
      }
      const char quote = text_[at_++];
      std::string value = ParseCharacterData(quote);
      Expect(std::string(1, quote));
      if (!element.attributes.emplace(attribute, value).second) {
        Fail("attribute " + attribute + " given twice");
      }
    }
    for (;;) {
      if (at_ >= text_.size()) Fail("<" + element.name + "> is not closed");
      if (LookingAt("</")) {
        at_ += 2;
        if (ParseName() != element.name) Fail("<" + element.name + "> closed by another tag");
        SkipSpace();
        Expect(">");
        return element;
      }
      if (LookingAt("<!--")) {
        SkipPast("-->");
      } else if (LookingAt("<?")) {
        SkipPast("?>");
      } else if (LookingAt("<!")) {
        Fail("CDATA and declarations are not read here");
      } else if (LookingAt("<")) {
        element.children.push_back(ParseElement());
      } else {
        element.text += ParseCharacterData('<');
      }
    }
  }

  const std::string& text_;
  std::size_t at_ = 0;
};

}  // namespace fleetmap::testing
