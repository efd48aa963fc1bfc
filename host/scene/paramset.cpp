// Parameter lists: parsing and typed lookup (pbrt-v4 parser.cpp parseParameters and
// paramdict.cpp ParameterDictionary, re-implemented with basalt's error policy).
#include "scene/paramset.h"

#include <algorithm>
#include <cmath>

namespace basalt {

namespace {

// What a declared type holds and how many numbers make one item.
struct TypeInfo {
  const char* name;
  enum { Numbers, Strings, Bools, NumbersOrStrings } values;
  int per_item;
};

constexpr TypeInfo kTypes[] = {
    {"float", TypeInfo::Numbers, 1},
    {"integer", TypeInfo::Numbers, 1},
    {"point2", TypeInfo::Numbers, 2},
    {"vector2", TypeInfo::Numbers, 2},
    {"point3", TypeInfo::Numbers, 3},
    {"vector3", TypeInfo::Numbers, 3},
    {"normal", TypeInfo::Numbers, 3},
    {"rgb", TypeInfo::Numbers, 3},
    {"blackbody", TypeInfo::Numbers, 1},
    {"bool", TypeInfo::Bools, 1},
    {"string", TypeInfo::Strings, 1},
    {"texture", TypeInfo::Strings, 1},
    {"spectrum", TypeInfo::NumbersOrStrings, 1},
};

// The canonical name of a declared type: pbrt-v3 spellings are aliases (pbrt-v4 --upgrade).
std::string canonical_type(const std::string& t) {
  if (t == "point") return "point3";
  if (t == "vector") return "vector3";
  if (t == "normal3") return "normal";
  if (t == "color") return "rgb";
  return t;
}

const TypeInfo* type_info(const std::string& t) {
  for (const TypeInfo& ti : kTypes)
    if (t == ti.name) return &ti;
  return nullptr;
}

// "parameter "name"" for messages.
std::string pname(const Param& p) { return "parameter \"" + p.name + "\""; }

// Checks the kind and count of the values read for p and stores them.
void check_values(Param& p, const std::vector<Token>& values) {
  const TypeInfo* ti = type_info(p.type);
  if (values.empty()) throw SceneError(p.loc, "no values given for " + pname(p));
  for (const Token& v : values) {
    bool is_bool_word = v.kind == Token::Kind::Word && (v.text == "true" || v.text == "false");
    switch (ti->values) {
      case TypeInfo::Numbers:
        if (v.kind != Token::Kind::Number)
          throw SceneError(
              p.loc, pname(p) + " of type " + p.type + " expects numbers, got " + v.describe());
        if (p.type == "integer" && !v.is_integer_literal())
          throw SceneError(p.loc,
                           pname(p) + " of type integer expects integers, got " + v.describe());
        p.numbers.push_back(v.number);
        break;
      case TypeInfo::Strings:
        if (v.kind != Token::Kind::String)
          throw SceneError(p.loc, pname(p) + " of type " + p.type +
                                      " expects quoted strings, got " + v.describe());
        p.strings.push_back(v.text);
        break;
      case TypeInfo::Bools:
        // true/false, bare or quoted (pbrt-v4 accepts both).
        if (is_bool_word ||
            (v.kind == Token::Kind::String && (v.text == "true" || v.text == "false")))
          p.bools.push_back(v.text == "true");
        else
          throw SceneError(p.loc,
                           pname(p) + " of type bool expects true or false, got " + v.describe());
        break;
      case TypeInfo::NumbersOrStrings:
        if (v.kind == Token::Kind::Number && p.strings.empty())
          p.numbers.push_back(v.number);
        else if (v.kind == Token::Kind::String && p.numbers.empty())
          p.strings.push_back(v.text);
        else
          throw SceneError(p.loc, pname(p) + " of type spectrum expects numbers or one name, got " +
                                      v.describe());
        break;
    }
  }
  std::size_t n = p.numbers.size();
  int per = p.type == "spectrum" ? 2 : ti->per_item;  // spectra: (lambda, value) pairs
  if (n % per != 0)
    throw SceneError(p.loc, pname(p) + " of type " + p.type + " needs a multiple of " +
                                std::to_string(per) + " values, got " + std::to_string(n));
}

}  // namespace

std::string format_warning(const SourceLoc& loc, const std::string& message) {
  return loc.str() + ": warning: " + message;
}

ParamSet parse_param_list(Tokenizer& tok) {
  ParamSet set;
  while (true) {
    const std::optional<Token>& peeked = tok.peek();
    if (!peeked || peeked->kind != Token::Kind::String) return set;
    Token decl = *tok.next();

    // "type name": exactly two words (pbrt-v4 parseParameters).
    Param p;
    p.loc = decl.loc;
    std::vector<std::string> words;
    std::string w;
    for (char c : decl.text + " ") {
      if (c == ' ' || c == '\t') {
        if (!w.empty()) words.push_back(w);
        w.clear();
      } else {
        w += c;
      }
    }
    if (words.size() != 2)
      throw SceneError(decl.loc, "malformed parameter declaration \"" + decl.text +
                                     "\" (expected \"type name\")");
    p.type = canonical_type(words[0]);
    p.name = words[1];
    if (!type_info(p.type))
      throw SceneError(
          decl.loc, "unknown parameter type \"" + words[0] + "\" for parameter \"" + p.name + "\"");

    // The value: one token, or a bracketed list.
    std::vector<Token> values;
    std::optional<Token> v = tok.next();
    auto is_value = [](const Token& t) {
      return t.kind == Token::Kind::Number || t.kind == Token::Kind::String ||
             (t.kind == Token::Kind::Word && (t.text == "true" || t.text == "false"));
    };
    if (v && v->kind == Token::Kind::LBracket) {
      SourceLoc open = v->loc;
      while (true) {
        v = tok.next();
        if (!v) throw SceneError(open, "missing ']' for " + pname(p));
        if (v->kind == Token::Kind::RBracket) break;
        if (!is_value(*v))
          throw SceneError(v->loc, "unexpected " + v->describe() + " in the values of " + pname(p) +
                                       " (missing ']'?)");
        values.push_back(std::move(*v));
      }
    } else if (v && is_value(*v)) {
      values.push_back(std::move(*v));
    } else {
      throw SceneError(p.loc, "no value given for " + pname(p));
    }
    check_values(p, values);
    set.params.push_back(std::move(p));
  }
}

const Param* ParamSet::find(const std::string& name) const {
  for (auto it = params.rbegin(); it != params.rend(); ++it)
    if (it->name == name) return &*it;
  return nullptr;
}

SourceLoc ParamSet::loc_of(const std::string& name, const SourceLoc& fallback) const {
  const Param* p = find(name);
  return p ? p->loc : fallback;
}

// The last parameter called name, checked to have one of the given types; marks it used.
const Param* ParamSet::lookup(const std::string& name,
                              std::initializer_list<const char*> types) const {
  const Param* p = find(name);
  if (!p) return nullptr;
  bool ok = false;
  std::string expected;
  for (const char* t : types) {
    ok = ok || p->type == t;
    expected += (expected.empty() ? "" : " or ") + std::string(t);
  }
  if (!ok) throw SceneError(p->loc, pname(*p) + " has type " + p->type + "; expected " + expected);
  p->used = true;
  return p;
}

// Throws unless p holds exactly one item of per numbers/strings/bools.
static void require_one(const Param& p, std::size_t count, std::size_t per) {
  if (count != per)
    throw SceneError(p.loc, "expected one value for " + pname(p) + ", got " +
                                std::to_string(count / per == 0 ? count : count / per));
}

float ParamSet::get_float(const std::string& name, float def) const {
  const Param* p = lookup(name, {"float"});
  if (!p) return def;
  require_one(*p, p->numbers.size(), 1);
  return float(p->numbers[0]);
}

int ParamSet::get_int(const std::string& name, int def) const {
  const Param* p = lookup(name, {"integer"});
  if (!p) return def;
  require_one(*p, p->numbers.size(), 1);
  if (p->numbers[0] > 2147483647.0 || p->numbers[0] < -2147483648.0)
    throw SceneError(p->loc, pname(*p) + " does not fit a 32-bit integer");
  return int(p->numbers[0]);
}

bool ParamSet::get_bool(const std::string& name, bool def) const {
  const Param* p = lookup(name, {"bool"});
  if (!p) return def;
  require_one(*p, p->bools.size(), 1);
  return p->bools[0];
}

std::string ParamSet::get_string(const std::string& name, const std::string& def) const {
  const Param* p = lookup(name, {"string"});
  if (!p) return def;
  require_one(*p, p->strings.size(), 1);
  return p->strings[0];
}

glm::vec3 ParamSet::get_point3(const std::string& name, glm::vec3 def) const {
  const Param* p = lookup(name, {"point3"});
  if (!p) return def;
  require_one(*p, p->numbers.size(), 3);
  return glm::vec3(p->numbers[0], p->numbers[1], p->numbers[2]);
}

std::vector<float> ParamSet::get_floats(const std::string& name) const {
  const Param* p = lookup(name, {"float"});
  std::vector<float> out;
  if (p)
    for (double d : p->numbers) out.push_back(float(d));
  return out;
}

std::vector<int> ParamSet::get_ints(const std::string& name) const {
  const Param* p = lookup(name, {"integer"});
  std::vector<int> out;
  if (!p) return out;
  out.reserve(p->numbers.size());
  for (double d : p->numbers) {
    if (d > 2147483647.0 || d < -2147483648.0)
      throw SceneError(p->loc, pname(*p) + " has a value that does not fit a 32-bit integer");
    out.push_back(int(d));
  }
  return out;
}

std::vector<glm::vec2> ParamSet::get_point2s(const std::string& name) const {
  const Param* p = lookup(name, {"point2"});
  std::vector<glm::vec2> out;
  if (p)
    for (std::size_t i = 0; i + 1 < p->numbers.size(); i += 2)
      out.emplace_back(p->numbers[i], p->numbers[i + 1]);
  return out;
}

// Groups of three numbers as vectors.
static std::vector<glm::vec3> triples(const Param* p) {
  std::vector<glm::vec3> out;
  if (p) {
    out.reserve(p->numbers.size() / 3);
    for (std::size_t i = 0; i + 2 < p->numbers.size(); i += 3)
      out.emplace_back(p->numbers[i], p->numbers[i + 1], p->numbers[i + 2]);
  }
  return out;
}

std::vector<glm::vec3> ParamSet::get_point3s(const std::string& name) const {
  return triples(lookup(name, {"point3"}));
}

std::vector<glm::vec3> ParamSet::get_normals(const std::string& name) const {
  return triples(lookup(name, {"normal"}));
}

std::optional<Spectrum> ParamSet::get_spectrum_curve(const std::string& name) const {
  const Param* p = lookup(name, {"rgb", "spectrum", "blackbody"});
  if (!p) return std::nullopt;
  if (p->type == "rgb")
    throw SceneError(p->loc, pname(*p) + " needs a spectrum here (a float, a named or tabulated "
                                         "spectrum), not an rgb value");
  if (p->type == "blackbody") {
    // pbrt-v4: "blackbody L" [ T ], the normalised BlackbodySpectrum(T).
    if (p->numbers.size() != 1)
      throw SceneError(p->loc, "blackbody " + pname(*p) +
                                   " takes one value, the temperature in Kelvin (pbrt-v4)");
    if (!(p->numbers[0] > 0.0) || !std::isfinite(p->numbers[0]))
      throw SceneError(p->loc, "blackbody " + pname(*p) + " needs a positive temperature");
    return Spectrum::blackbody(p->numbers[0]);
  }
  if (!p->strings.empty()) {
    if (p->strings.size() != 1)
      throw SceneError(p->loc, pname(*p) + " expects one spectrum name");
    std::optional<Spectrum> s = named_spectrum(p->strings[0]);
    if (!s) {
      std::string known;
      for (const std::string& n : named_spectrum_names()) known += (known.empty() ? "" : ", ") + n;
      throw SceneError(p->loc, "unknown named spectrum \"" + p->strings[0] + "\" for " + pname(*p) +
                                   " (basalt knows " + known + ")");
    }
    return s;
  }
  // (lambda, value) pairs with increasing wavelengths (pbrt-v4 PiecewiseLinearSpectrum).
  const std::vector<double>& v = p->numbers;
  if (v.size() < 2) throw SceneError(p->loc, pname(*p) + " needs (wavelength, value) pairs");
  for (std::size_t i = 2; i < v.size(); i += 2)
    if (v[i] <= v[i - 2]) throw SceneError(p->loc, pname(*p) + ": wavelengths must increase");
  for (double x : v)
    if (!std::isfinite(x)) throw SceneError(p->loc, pname(*p) + " has a non-finite value");
  return Spectrum::from_pairs(v.data(), v.size());
}

std::vector<std::string> ParamSet::get_strings(const std::string& name) const {
  const Param* p = lookup(name, {"string"});
  return p ? p->strings : std::vector<std::string>{};
}

std::optional<glm::vec3> ParamSet::get_spectrum(const std::string& name, SpectrumUse use,
                                                std::vector<std::string>* /*warnings*/) const {
  const Param* p = lookup(name, {"rgb", "spectrum", "blackbody"});
  if (!p) return std::nullopt;
  glm::vec3 rgb;
  if (p->type == "rgb") {
    require_one(*p, p->numbers.size(), 3);
    rgb = glm::vec3(p->numbers[0], p->numbers[1], p->numbers[2]);
  } else {
    Spectrum s = *get_spectrum_curve(name);
    glm::dvec3 c = use == SpectrumUse::Illuminant ? spectrum_to_rgb_illuminant(s)
                                                  : spectrum_to_rgb_reflectance(s);
    rgb = glm::vec3(c);
    if (use == SpectrumUse::Illuminant) rgb = glm::max(rgb, glm::vec3(0.0f));  // out of gamut
    if (p->type == "spectrum" && p->strings.empty())
      for (std::size_t i = 1; i < p->numbers.size(); i += 2)
        if (p->numbers[i] < 0) throw SceneError(p->loc, pname(*p) + " has a negative value");
    if (use == SpectrumUse::Albedo && p->type == "spectrum" && p->strings.empty())
      for (std::size_t i = 1; i < p->numbers.size(); i += 2)
        if (p->numbers[i] > 1)
          throw SceneError(p->loc, pname(*p) + " is a reflectance and has a value above 1");
  }
  if (!std::isfinite(rgb.x) || !std::isfinite(rgb.y) || !std::isfinite(rgb.z))
    throw SceneError(p->loc, pname(*p) + " is not finite");
  if (rgb.x < 0 || rgb.y < 0 || rgb.z < 0)
    throw SceneError(p->loc, pname(*p) + " has a negative component");
  if (use == SpectrumUse::Albedo && (rgb.x > 1 || rgb.y > 1 || rgb.z > 1))
    throw SceneError(p->loc, pname(*p) + " is a reflectance and has a component above 1");
  return rgb;
}

void ParamSet::report_unused(const std::string& what, std::vector<std::string>& warnings) const {
  // pbrt-v4 ReportUnused: an unused parameter shadowed by a later used one of the same name
  // and type is fine.
  for (std::size_t i = 0; i < params.size(); ++i) {
    const Param& p = params[i];
    if (p.used) continue;
    bool shadowed = std::any_of(params.begin() + i + 1, params.end(), [&](const Param& q) {
      return q.used && q.name == p.name && q.type == p.type;
    });
    if (!shadowed)
      warnings.push_back(format_warning(p.loc, "unused parameter \"" + p.type + " " + p.name +
                                                   "\" for " + what +
                                                   " (not supported by basalt; ignored)"));
  }
}

}  // namespace basalt
