// A minimal JSON object writer for run summaries (numbers, strings, booleans, number and string
// arrays).
#pragma once

#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

namespace wet_curly_hair {
namespace io {

class JsonObject {
 public:
  JsonObject& add(const std::string& key, double v) { return raw(key, number(v)); }
  JsonObject& add(const std::string& key, long long v) { return raw(key, std::to_string(v)); }
  JsonObject& add(const std::string& key, int v) { return raw(key, std::to_string(v)); }
  JsonObject& add(const std::string& key, unsigned long long v) {
    return raw(key, std::to_string(v));
  }
  JsonObject& add(const std::string& key, unsigned long v) { return raw(key, std::to_string(v)); }
  JsonObject& add(const std::string& key, bool v) { return raw(key, v ? "true" : "false"); }
  JsonObject& add(const std::string& key, const std::string& v) { return raw(key, quote(v)); }
  JsonObject& add(const std::string& key, const char* v) { return raw(key, quote(v)); }
  JsonObject& add(const std::string& key, const std::vector<double>& v) {
    std::string s = "[";
    for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + number(v[i]);
    return raw(key, s + "]");
  }
  JsonObject& add(const std::string& key, const std::vector<std::string>& v) {
    std::string s = "[";
    for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + quote(v[i]);
    return raw(key, s + "]");
  }
  JsonObject& addObject(const std::string& key, const JsonObject& o) { return raw(key, o.str()); }
  std::string str() const { return "{\n" + body_ + "\n}"; }

  static std::string number(double v) {
    if (!std::isfinite(v)) return "null";  // JSON has no NaN/Inf
    std::ostringstream s;
    s << std::setprecision(10) << v;
    return s.str();
  }
  static std::string quote(const std::string& v) {
    std::string s = "\"";
    for (char c : v) {
      if (c == '"' || c == '\\') s += '\\';
      if (static_cast<unsigned char>(c) < 0x20) {
        s += ' ';
        continue;
      }
      s += c;
    }
    return s + "\"";
  }

 private:
  JsonObject& raw(const std::string& key, const std::string& value) {
    if (!body_.empty()) body_ += ",\n";
    body_ += "  " + quote(key) + ": " + value;
    return *this;
  }
  std::string body_;
};

}  // namespace io
}  // namespace wet_curly_hair
