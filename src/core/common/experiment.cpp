#include "xpersif/core/common/experiment.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <set>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

const std::vector<std::string>& pushSides() {
  static const std::vector<std::string> sides{"-x", "+x", "-y", "+y"};
  return sides;
}

const ObjectFeatures* FeatureVector::find(const std::string& name) const {
  for (const auto& object : objects) {
    if (object.name == name) return &object;
  }
  return nullptr;
}

double wrapAngle(double angle) {
  double wrapped = std::remainder(angle, 2.0 * M_PI);  // in [-pi, pi]
  if (wrapped <= -M_PI) wrapped += 2.0 * M_PI;
  return wrapped;
}

double pushAngleInObject(const std::string& side) {
  if (side == "-x") return 0.0;
  if (side == "+x") return M_PI;
  if (side == "-y") return M_PI / 2.0;
  if (side == "+y") return -M_PI / 2.0;
  throwIfInvalid(checkOneOf("side", side, pushSides()));
  return 0.0;  // not reached
}

Outcome computeOutcome(const ObjectFeatures& before, const ObjectFeatures& after, const std::string& side) {
  const double push_heading = before.yaw + pushAngleInObject(side);
  requireAllFinite("before pose", {before.x, before.y, before.yaw});
  requireAllFinite("after pose", {after.x, after.y, after.yaw});
  const double wx = after.x - before.x, wy = after.y - before.y;
  const double c = std::cos(push_heading), s = std::sin(push_heading);
  Outcome outcome;
  outcome.dx = c * wx + s * wy;
  outcome.dy = -s * wx + c * wy;
  outcome.dyaw = wrapAngle(after.yaw - before.yaw);
  return outcome;
}

std::string checkExperiment(const std::string& field, const Experiment& e) {
  if (e.object.empty()) return field + ".object is empty; the pushed object's name is required";
  std::string message = checkMaxLength(field + ".object", e.object, kMaxNameLength);
  if (message.empty()) message = checkOneOf(field + ".side", e.side, pushSides());
  if (message.empty()) message = checkInRange(field + ".offset", e.offset, -kMaxPushExtent, kMaxPushExtent);
  if (message.empty()) message = checkInRange(field + ".distance", e.distance, 0.0, kMaxPushExtent);
  if (message.empty() && e.distance <= 0.0) {
    message = field + ".distance is " + describeNumber(e.distance) + "; it must be greater than zero";
  }
  return message;
}

std::string checkOutcome(const std::string& field, const Outcome& o) {
  std::string message = checkFinite(field + ".dx", o.dx);
  if (message.empty()) message = checkFinite(field + ".dy", o.dy);
  if (message.empty()) message = checkInRange(field + ".dyaw", o.dyaw, -M_PI, M_PI);
  return message;
}

std::string checkFeatureVector(const std::string& field, const FeatureVector& f) {
  std::string message = checkFinite(field + ".stamp", f.stamp);
  if (message.empty()) message = checkMaxSize(field + ".objects", f.objects.size(), kMaxObjectsPerFeatureVector);
  std::set<std::string> names;
  for (std::size_t i = 0; i < f.objects.size() && message.empty(); ++i) {
    const ObjectFeatures& o = f.objects[i];
    const std::string at = field + ".objects[" + std::to_string(i) + "]";
    if (o.name.empty()) return at + ".name is empty; every object needs a name";
    message = checkMaxLength(at + ".name", o.name, kMaxNameLength);
    if (message.empty() && !names.insert(o.name).second) {
      message = at + ".name '" + o.name + "' appears twice; object names must be unique";
    }
    if (message.empty()) message = checkFinite(at + ".x", o.x);
    if (message.empty()) message = checkFinite(at + ".y", o.y);
    if (message.empty()) message = checkFinite(at + ".yaw", o.yaw);
    if (message.empty()) message = checkMaxSize(at + ".extra", o.extra.size(), kMaxExtraFeatures);
    for (auto it = o.extra.begin(); it != o.extra.end() && message.empty(); ++it) {
      if (it->first.empty()) return at + ".extra has a feature with an empty name";
      message = checkMaxLength(at + ".extra name", it->first, kMaxNameLength);
      if (message.empty()) message = checkFinite(at + ".extra[" + it->first + "]", it->second);
    }
  }
  return message;
}

void requireExperiment(const std::string& field, const Experiment& e) { throwIfInvalid(checkExperiment(field, e)); }
void requireOutcome(const std::string& field, const Outcome& o) { throwIfInvalid(checkOutcome(field, o)); }
void requireFeatureVector(const std::string& field, const FeatureVector& f) {
  throwIfInvalid(checkFeatureVector(field, f));
}

// ---- JSON ------------------------------------------------------------------------------------------------

namespace {

void writeString(std::string& out, const std::string& text) {
  out += '"';
  for (unsigned char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\b': out += "\\b"; break;
      case '\f': out += "\\f"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (c < 0x20) {
          char buffer[8];
          std::snprintf(buffer, sizeof buffer, "\\u%04x", c);
          out += buffer;
        } else {
          out += static_cast<char>(c);  // UTF-8 bytes pass through unchanged
        }
    }
  }
  out += '"';
}

void writeNumber(std::string& out, const std::string& field, double value) {
  requireFinite(field, value);
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  out += buffer;
}

/// A parsed JSON value: only what the feature vector format needs, but the grammar is all of JSON.
struct Json {
  enum class Type { Null, Bool, Number, String, Array, Object } type = Type::Null;
  bool boolean = false;
  double number = 0.0;
  std::string text;
  std::vector<Json> items;                             // Array
  std::vector<std::pair<std::string, Json>> members;   // Object, in order
};

class JsonParser {
 public:
  explicit JsonParser(const std::string& text) : s_(text) {}

  Json parseDocument() {
    Json value = parseValue(0);
    skipSpace();
    if (i_ != s_.size()) fail("unexpected text after the JSON value");
    return value;
  }

 private:
  static constexpr int kMaxDepth = 32;

  [[noreturn]] void fail(const std::string& why) const {
    throw ValidationError("feature vector JSON is malformed at character " + std::to_string(i_) + ": " + why);
  }
  void skipSpace() {
    while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t' || s_[i_] == '\n' || s_[i_] == '\r')) ++i_;
  }
  void expect(char c) {
    skipSpace();
    if (i_ >= s_.size() || s_[i_] != c) fail(std::string("expected '") + c + "'");
    ++i_;
  }
  bool literal(const char* word) {
    const std::size_t n = std::char_traits<char>::length(word);
    if (s_.compare(i_, n, word) != 0) return false;
    i_ += n;
    return true;
  }

  Json parseValue(int depth) {
    if (depth > kMaxDepth) fail("nesting is deeper than " + std::to_string(kMaxDepth));
    skipSpace();
    if (i_ >= s_.size()) fail("unexpected end of text");
    Json value;
    const char c = s_[i_];
    if (c == '{') {
      value.type = Json::Type::Object;
      ++i_;
      skipSpace();
      if (i_ < s_.size() && s_[i_] == '}') { ++i_; return value; }
      for (;;) {
        skipSpace();
        std::string key = parseString();
        expect(':');
        value.members.emplace_back(std::move(key), parseValue(depth + 1));
        skipSpace();
        if (i_ < s_.size() && s_[i_] == ',') { ++i_; continue; }
        expect('}');
        return value;
      }
    }
    if (c == '[') {
      value.type = Json::Type::Array;
      ++i_;
      skipSpace();
      if (i_ < s_.size() && s_[i_] == ']') { ++i_; return value; }
      for (;;) {
        value.items.push_back(parseValue(depth + 1));
        skipSpace();
        if (i_ < s_.size() && s_[i_] == ',') { ++i_; continue; }
        expect(']');
        return value;
      }
    }
    if (c == '"') {
      value.type = Json::Type::String;
      value.text = parseString();
      return value;
    }
    if (literal("true")) { value.type = Json::Type::Bool; value.boolean = true; return value; }
    if (literal("false")) { value.type = Json::Type::Bool; return value; }
    if (literal("null")) return value;
    value.type = Json::Type::Number;
    value.number = parseNumber();
    return value;
  }

  double parseNumber() {
    // Check the JSON number grammar, then let strtod convert (it rounds correctly).
    const std::size_t start = i_;
    auto digits = [&] {
      const std::size_t from = i_;
      while (i_ < s_.size() && s_[i_] >= '0' && s_[i_] <= '9') ++i_;
      return i_ > from;
    };
    if (i_ < s_.size() && s_[i_] == '-') ++i_;
    if (i_ < s_.size() && s_[i_] == '0') ++i_;
    else if (!digits()) fail("expected a value");
    if (i_ < s_.size() && s_[i_] == '.') { ++i_; if (!digits()) fail("expected digits after '.'"); }
    if (i_ < s_.size() && (s_[i_] == 'e' || s_[i_] == 'E')) {
      ++i_;
      if (i_ < s_.size() && (s_[i_] == '+' || s_[i_] == '-')) ++i_;
      if (!digits()) fail("expected digits in the exponent");
    }
    const std::string token = s_.substr(start, i_ - start);
    const double value = std::strtod(token.c_str(), nullptr);
    if (!std::isfinite(value)) fail("number " + token + " is out of range");
    return value;
  }

  unsigned hex4() {
    if (i_ + 4 > s_.size()) fail("truncated \\u escape");
    unsigned code = 0;
    for (int k = 0; k < 4; ++k) {
      const char h = s_[i_++];
      code <<= 4;
      if (h >= '0' && h <= '9') code |= h - '0';
      else if (h >= 'a' && h <= 'f') code |= h - 'a' + 10;
      else if (h >= 'A' && h <= 'F') code |= h - 'A' + 10;
      else fail("bad hex digit in \\u escape");
    }
    return code;
  }

  static void appendUtf8(std::string& out, unsigned code) {
    if (code < 0x80) {
      out += static_cast<char>(code);
    } else if (code < 0x800) {
      out += static_cast<char>(0xC0 | (code >> 6));
      out += static_cast<char>(0x80 | (code & 0x3F));
    } else if (code < 0x10000) {
      out += static_cast<char>(0xE0 | (code >> 12));
      out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (code & 0x3F));
    } else {
      out += static_cast<char>(0xF0 | (code >> 18));
      out += static_cast<char>(0x80 | ((code >> 12) & 0x3F));
      out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (code & 0x3F));
    }
  }

  std::string parseString() {
    if (i_ >= s_.size() || s_[i_] != '"') fail("expected a string");
    ++i_;
    std::string out;
    for (;;) {
      if (i_ >= s_.size()) fail("unterminated string");
      const unsigned char c = static_cast<unsigned char>(s_[i_++]);
      if (c == '"') return out;
      if (c < 0x20) fail("control character in a string");
      if (c != '\\') { out += static_cast<char>(c); continue; }
      if (i_ >= s_.size()) fail("unterminated escape");
      const char e = s_[i_++];
      switch (e) {
        case '"': out += '"'; break;
        case '\\': out += '\\'; break;
        case '/': out += '/'; break;
        case 'b': out += '\b'; break;
        case 'f': out += '\f'; break;
        case 'n': out += '\n'; break;
        case 'r': out += '\r'; break;
        case 't': out += '\t'; break;
        case 'u': {
          unsigned code = hex4();
          if (code >= 0xD800 && code <= 0xDBFF) {  // a surrogate pair
            if (!(literal("\\u"))) fail("lone high surrogate in \\u escape");
            const unsigned low = hex4();
            if (low < 0xDC00 || low > 0xDFFF) fail("bad low surrogate in \\u escape");
            code = 0x10000 + ((code - 0xD800) << 10) + (low - 0xDC00);
          } else if (code >= 0xDC00 && code <= 0xDFFF) {
            fail("lone low surrogate in \\u escape");
          }
          appendUtf8(out, code);
          break;
        }
        default: fail(std::string("unknown escape '\\") + e + "'");
      }
    }
  }

  const std::string& s_;
  std::size_t i_ = 0;
};

[[noreturn]] void badShape(const std::string& why) {
  throw ValidationError("feature vector JSON has the wrong shape: " + why);
}

double numberOf(const Json& value, const std::string& field) {
  if (value.type != Json::Type::Number) badShape(field + " must be a number");
  return value.number;
}

}  // namespace

std::string toJson(const FeatureVector& features) {
  std::string out = "{\"stamp\":";
  writeNumber(out, "stamp", features.stamp);
  out += ",\"objects\":[";
  for (std::size_t i = 0; i < features.objects.size(); ++i) {
    const ObjectFeatures& o = features.objects[i];
    const std::string at = "objects[" + std::to_string(i) + "]";
    if (i) out += ',';
    out += "{\"name\":";
    writeString(out, o.name);
    out += ",\"x\":";
    writeNumber(out, at + ".x", o.x);
    out += ",\"y\":";
    writeNumber(out, at + ".y", o.y);
    out += ",\"yaw\":";
    writeNumber(out, at + ".yaw", o.yaw);
    out += ",\"extra\":{";
    bool first = true;
    for (const auto& [key, value] : o.extra) {
      if (!first) out += ',';
      first = false;
      writeString(out, key);
      out += ':';
      writeNumber(out, at + ".extra[" + key + "]", value);
    }
    out += "}}";
  }
  out += "]}";
  return out;
}

FeatureVector featureVectorFromJson(const std::string& json) {
  const Json root = JsonParser(json).parseDocument();
  if (root.type != Json::Type::Object) badShape("the top level must be an object");
  FeatureVector features;
  bool have_objects = false;
  for (const auto& [key, value] : root.members) {
    if (key == "stamp") {
      features.stamp = numberOf(value, "stamp");
    } else if (key == "objects") {
      if (value.type != Json::Type::Array) badShape("objects must be an array");
      have_objects = true;
      for (std::size_t i = 0; i < value.items.size(); ++i) {
        const Json& item = value.items[i];
        const std::string at = "objects[" + std::to_string(i) + "]";
        if (item.type != Json::Type::Object) badShape(at + " must be an object");
        ObjectFeatures object;
        bool have_name = false;
        for (const auto& [k, v] : item.members) {
          if (k == "name") {
            if (v.type != Json::Type::String) badShape(at + ".name must be a string");
            object.name = v.text;
            have_name = true;
          } else if (k == "x") {
            object.x = numberOf(v, at + ".x");
          } else if (k == "y") {
            object.y = numberOf(v, at + ".y");
          } else if (k == "yaw") {
            object.yaw = numberOf(v, at + ".yaw");
          } else if (k == "extra") {
            if (v.type != Json::Type::Object) badShape(at + ".extra must be an object");
            for (const auto& [name, number] : v.members) object.extra[name] = numberOf(number, at + ".extra." + name);
          } else {
            badShape(at + " has an unknown key '" + k + "'");
          }
        }
        if (!have_name) badShape(at + " has no name");
        features.objects.push_back(std::move(object));
      }
    } else {
      badShape("unknown key '" + key + "' at the top level");
    }
  }
  if (!have_objects) badShape("the objects array is missing");
  requireFeatureVector("feature vector", features);
  return features;
}

}  // namespace xpersif::core
