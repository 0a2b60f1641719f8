// The compare file (framework/compare.hpp): reading and checking it, its cases, and the scenes of
// its settings and preparations. Running it and its report: compare.cpp.
#include "framework/compare.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "analysis/compare.hpp"
#include "driver/run.hpp"
#include "framework/report.hpp"
#include "lib/error.hpp"
#include "sweep/plan.hpp"

namespace jamflow::studies {

namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Keys a setting (or the preparation) may override: what changes the method or the state point,
// not what makes the runs comparable (start state, seed, averaging window, sampling) nor what
// the sweep sets (output, threads, replicas). A setting may also set its own run.t_eq (the
// transient it discards: a setting continued from another one's steady state needs less).
bool overridable(const std::string& section, const std::string& key, bool setting) {
  if (section == "integrator" || section == "ensemble")
    return true;
  if (section == "system")
    return key == "alpha" || key == "skin" || (setting && key == "N");
  if (section == "shear")
    return key == "rate";
  if (section == "run")
    return key == "max_force_evaluations" || (setting && key == "t_eq");
  return false;
}
constexpr const char* kOverridable =
    "integrator.*, ensemble.*, system.alpha, system.skin, shear.rate, "
    "run.max_force_evaluations, and in a [[setting]] system.N and run.t_eq";

std::string show(const toml::node& v) {
  std::ostringstream os;
  v.visit([&](const auto& x) { os << x; });
  return os.str();
}

// The overrides of a [[setting]] or [prepare] table: nested tables (integrator = {...},
// integrator.dt = 0.1) and quoted dotted keys ("integrator.dt" = 0.1) alike, as section ->
// table. `skip`: keys of the table itself (label, t, init).
toml::table read_overrides(const toml::table& t, const std::string& where,
                           const std::vector<std::string>& skip, bool setting) {
  toml::table out;
  auto add = [&](const std::string& section, const std::string& key, const toml::node& v) {
    if (!overridable(section, key, setting))
      throw ConfigError(where + ": key " + section + "." + key + " = " + show(v) +
                        " cannot be overridden here; allowed " + kOverridable);
    if (v.is_table() || v.is_array_of_tables())
      throw ConfigError(where + ": key " + section + "." + key + " is a table; allowed a value");
    if (!out.contains(section))
      out.insert(section, toml::table{});
    if (out[section].as_table()->contains(key))
      throw ConfigError(where + ": key " + section + "." + key + " given twice; allowed once");
    out[section].as_table()->insert(key, v);
  };
  for (const auto& [k, v] : t) {
    const std::string key(k.str());
    if (std::find(skip.begin(), skip.end(), key) != skip.end())
      continue;
    if (const toml::table* sub = v.as_table()) {
      for (const auto& [k2, v2] : *sub)
        add(key, std::string(k2.str()), v2);
    } else if (const auto dot = key.find('.'); dot != std::string::npos && dot > 0) {
      add(key.substr(0, dot), key.substr(dot + 1), v);
    } else {
      std::string allowed;
      for (const auto& s : skip)
        allowed += s + ", ";
      throw ConfigError(where + ": unknown key " + key + " = " + show(v) + "; allowed " + allowed +
                        "and overrides " + kOverridable);
    }
  }
  return out;
}

// Applies overrides to a scene: a section whose override names another `kind` is replaced whole
// (another integrator's or ensemble's keys do not carry over), others are merged key by key.
void apply_overrides(Scene& scene, const toml::table& overrides) {
  for (const auto& [sec, node] : overrides) {
    const std::string section(sec.str());
    const toml::table& keys = *node.as_table();
    toml::table merged = scene.table(section) ? *scene.table(section) : toml::table{};
    const toml::node* kind = keys.get("kind");
    const toml::node* base_kind = merged.get("kind");
    if (kind && (!base_kind || show(*kind) != show(*base_kind)))
      merged = toml::table{};
    for (const auto& [k, v] : keys)
      merged.insert_or_assign(k.str(), v);
    scene.set_section(section, std::move(merged));
  }
}

std::int64_t scene_n(const Scene& scene) {
  const toml::table* sys = scene.table("system");
  const toml::node* n = sys ? sys->get("N") : nullptr;
  return n && n->is_integer() ? n->as_integer()->get() : 0;
}

bool valid_label(const std::string& s) {
  if (s.empty() || s.size() > 64)
    return false;
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' ||
          c == '+' || c == '='))
      return false;
  return s != "." && s != "..";
}

}  // namespace

const std::vector<std::string>& compare_observables() {
  static const std::vector<std::string> kObservables = {"sigma_xy", "pressure",    "phi",
                                                        "energy",   "dissipation", "eta"};
  return kObservables;
}

double typical_overlap(const Scene& scene, double measured) {
  const toml::table* sys = scene.table("system");
  const toml::node* a = sys ? sys->get("alpha") : nullptr;
  const double alpha = a && a->is_number() ? a->value<double>().value_or(2.0) : 2.0;
  const toml::table* ens = scene.table("ensemble");
  const toml::node* kind = ens ? ens->get("kind") : nullptr;
  const toml::node* p = ens ? ens->get("pressure") : nullptr;
  double pressure = measured;
  if (kind && kind->value<std::string>() == std::string("constant_pressure") && p && p->is_number())
    pressure = p->value<double>().value_or(measured);
  if (!(std::isfinite(pressure) && pressure > 0.0))
    pressure = 1e-3;
  return std::clamp(std::pow(pressure, 1.0 / (alpha - 1.0)), 1e-9, 1.0);
}

Scene ComparePlan::setting_scene(std::size_t s, double measured_pressure) const {
  Scene scene = base;
  apply_overrides(scene, settings[s].overrides);
  // integrator.atol_overlaps = x: atol = x delta, the typical overlap at this state point.
  if (const toml::table* in = scene.table("integrator"); in && in->contains("atol_overlaps")) {
    toml::table integrator = *in;
    const double x = integrator["atol_overlaps"].value<double>().value_or(-1.0);
    if (!(x > 0.0))
      throw ConfigError("integrator.atol_overlaps = " + show(*integrator.get("atol_overlaps")) +
                        "; allowed a number > 0");
    if (integrator.contains("atol"))
      throw ConfigError("integrator.atol with integrator.atol_overlaps; allowed one of them");
    integrator.erase("atol_overlaps");
    integrator.insert("atol", x * typical_overlap(scene, measured_pressure));
    scene.set_section("integrator", std::move(integrator));
  }
  toml::table r = scene.table("run") ? *scene.table("run") : toml::table{};
  for (const auto& [k, v] : run)
    r.insert_or_assign(k.str(), v);
  if (const toml::table* o = settings[s].overrides.get_as<toml::table>("run"))
    for (const auto& [k, v] : *o)
      r.insert_or_assign(k.str(), v);
  for (const char* k : {"replicas", "target_error", "max_time"})
    r.erase(k);
  scene.set_section("run", std::move(r));
  if (!init.empty())
    scene.set_value("system.init", toml::value<std::string>(init));
  return scene;
}

WindowOptions ComparePlan::window_options(std::size_t s, double measured_pressure) const {
  WindowOptions w;
  w.adaptive_step = window_step;
  if (window_step_contact) {
    const Scene scene = setting_scene(s, measured_pressure);
    const toml::table* sys = scene.table("system");
    const toml::node* a = sys ? sys->get("alpha") : nullptr;
    const double alpha = a && a->is_number() ? a->value<double>().value_or(2.0) : 2.0;
    const double k =
        (alpha - 1.0) * std::pow(typical_overlap(scene, measured_pressure), alpha - 2.0);
    w.adaptive_step = 0.1 / std::max(k, 1.0);
  }
  return w;
}

Scene ComparePlan::prepare_scene(std::int64_t n) const {
  Scene scene = base;
  apply_overrides(scene, prepare_overrides);
  scene.set_value("system.N", toml::value<std::int64_t>(n));
  // The whole run is the preparation: no window is averaged over that matters, but a run needs
  // one, so the second half is its window (its summary says whether it is steady).
  toml::table r = scene.table("run") ? *scene.table("run") : toml::table{};
  const toml::node* se = r.get("sample_every");
  double every = prepare_sample_every    ? *prepare_sample_every
                 : se && se->is_number() ? se->value<double>().value_or(1.0)
                                         : 1.0;
  // At least one sample per block in the window (the run's check), else half of t.
  const toml::node* b = r.get("blocks");
  const double blocks = b && b->is_integer() ? double(b->as_integer()->get()) : 20.0;
  const double half = every * std::max(blocks, std::ceil(0.5 * prepare_t / every));
  for (const char* k : {"replicas", "target_error", "max_time", "max_force_evaluations"})
    r.erase(k);
  r.insert_or_assign("sample_every", every);
  r.insert_or_assign("t_eq", half);
  r.insert_or_assign("t_av", half);
  scene.set_section("run", std::move(r));
  return scene;
}

CompareMethod compare_method(const ComparePlan& plan, std::size_t setting) {
  const Scene scene = plan.setting_scene(setting);
  const toml::table* in = scene.table("integrator");
  CompareMethod m;
  m.kind = in ? (*in)["kind"].value_or(std::string("euler")) : std::string("euler");
  m.family = m.kind;
  if (!in)
    return m;
  if (m.kind == "euler" || m.kind == "respa")
    m.dt = (*in)["dt"].value_or(kNaN);
  if (m.kind == "cvode" || m.kind == "rkc")
    m.rtol = (*in)["rtol"].value_or(kNaN);
  if (m.kind == "respa") {
    const std::string scheme = (*in)["inner_scheme"].value_or(std::string("euler"));
    const std::string inner = (*in)["inner"].value_or(std::string("particles"));
    m.family.append(" ").append(inner).append("x");
    m.family.append(std::to_string((*in)["n_inner"].value_or(std::int64_t{1})));
    if (scheme != "euler")
      m.family.append(" ").append(scheme);
  }
  return m;
}

std::vector<std::int64_t> ComparePlan::sizes() const {
  std::vector<std::int64_t> out;
  for (const auto& s : settings)
    if (std::find(out.begin(), out.end(), s.n) == out.end())
      out.push_back(s.n);
  return out;
}

namespace {
void check_plan(ComparePlan& plan, const std::string& where);
ComparePlan case_plan(const ComparePlan& plan, const toml::table& t, const std::string& label,
                      const std::string& where);
}  // namespace

ComparePlan parse_compare(const std::string& text, const std::string& source,
                          const std::string& base_dir) {
  // Scene::parse checks what toml++ must not see (non-ASCII outside strings) and names the line
  // of a syntax error; the root table is then read as it is.
  (void)Scene::parse(text, source);
  const toml::table top = toml::parse(text, source);
  for (const auto& [k, v] : top) {
    const std::string key(k.str());
    static const std::vector<std::string> kKeys = {
        "base",        "prepare",         "run",
        "setting",     "reference",       "replicas",
        "observables", "tolerance_sigma", "relative_tolerance",
        "case",        "diagnose",        "window_step",
        "study"};
    if (std::find(kKeys.begin(), kKeys.end(), key) == kKeys.end())
      throw ConfigError(source + ": unknown key " + key + " = " + show(v) + "; allowed " +
                        join(kKeys));
  }
  ComparePlan plan;
  plan.path = source;
  plan.name = fs::path(source).stem().string();
  const std::string where = source + ": ";

  // [base]: scene = "FILE" or the scene's sections inline.
  const toml::table* base = top.get_as<toml::table>("base");
  if (!base)
    throw ConfigError(where +
                      "no [base] section; allowed [base] scene = \"FILE\" or inline "
                      "[base.system], [base.ensemble], ... tables");
  const toml::node* scene_key = base->get("scene");
  if (scene_key && base->size() > 1)
    throw ConfigError(where +
                      "[base] has scene = \"FILE\" and inline sections; allowed one of "
                      "them");
  plan.base = sweep::load_base_scene(scene_key, scene_key ? nullptr : base, base_dir, source,
                                     "[base] scene", "[base]", "the compare file");
  if (const toml::table* sys = plan.base.table("system"); sys && sys->contains("init"))
    throw ConfigError(where +
                      "[base] scene has system.init; allowed a scene with N and phi (the "
                      "start state comes from [prepare])");
  if (const toml::table* sys = plan.base.table("system"))
    if (const toml::node* s = sys->get("seed"); s && s->is_integer() && s->as_integer()->get() >= 0)
      plan.seed = static_cast<std::uint64_t>(s->as_integer()->get());

  // Top-level keys.
  ConfigSection top_keys("compare file", &top);
  plan.replicas = top_keys.integer("replicas", 1, 1, 1000);
  plan.tolerance_sigma = top_keys.number("tolerance_sigma", 2.0, Range::positive());
  if (const toml::node* d = top.get("diagnose")) {
    if (!d->is_boolean())
      throw ConfigError(where + "diagnose = " + show(*d) + "; allowed true or false");
    plan.diagnose = d->as_boolean()->get();
  }
  if (const toml::node* w = top.get("window_step")) {
    const auto rule = w->value<std::string>();
    const double step = w->is_number() ? w->value<double>().value_or(0.0) : 0.0;
    if (rule && *rule == "contact")
      plan.window_step_contact = true;
    else if (w->is_number() && step > 0.0 && std::isfinite(step))
      plan.window_step = step;
    else
      throw ConfigError(where + "window_step = " + show(*w) +
                        "; allowed a number > 0 or \"contact\"");
  }
  if (const toml::node* st = top.get("study")) {
    if (!st->is_table())
      throw ConfigError(where + "study = " + show(*st) + "; allowed a [study] table");
    plan.study_keys = *st->as_table();
  }
  const std::vector<std::string>& allowed_obs = compare_observables();
  if (const toml::node* obs = top.get("observables")) {
    const toml::array* a = obs->as_array();
    if (!a || a->empty())
      throw ConfigError(where + "observables = " + show(*obs) + "; allowed a non-empty list of " +
                        join(allowed_obs));
    for (const auto& o : *a) {
      const auto s = o.value<std::string>();
      if (!s || std::find(allowed_obs.begin(), allowed_obs.end(), *s) == allowed_obs.end())
        throw ConfigError(where + "observables: " + show(o) + " is not allowed; allowed " +
                          join(allowed_obs));
      if (std::find(plan.observables.begin(), plan.observables.end(), *s) != plan.observables.end())
        throw ConfigError(where + "observables: \"" + *s + "\" given twice; allowed once");
      plan.observables.push_back(*s);
    }
  } else {
    plan.observables = {"sigma_xy", "pressure", "phi"};
  }
  plan.relative_tolerance.assign(plan.observables.size(), 0.0);
  if (const toml::node* rt = top.get("relative_tolerance")) {
    const toml::table* t = rt->as_table();
    if (!t)
      throw ConfigError(where + "relative_tolerance = " + show(*rt) +
                        "; allowed a table {observable = value}");
    ConfigSection sec("relative_tolerance", t);
    for (std::size_t o = 0; o < plan.observables.size(); ++o)
      plan.relative_tolerance[o] = sec.number(plan.observables[o], 0.0, Range::non_negative());
    sec.finish();
  }

  // [run]: the averaging every setting shares.
  const toml::table* run = top.get_as<toml::table>("run");
  ConfigSection run_sec("run", run);
  if (!run)
    throw ConfigError(where + "no [run] section; allowed [run] t_eq = T, t_av = T");
  plan.run.insert("t_eq", run_sec.number("t_eq", Range::non_negative()));
  plan.run.insert("t_av", run_sec.number("t_av", Range::positive()));
  if (run_sec.has("sample_every"))
    plan.run.insert("sample_every", run_sec.number("sample_every", Range::positive()));
  if (run_sec.has("max_force_evaluations"))
    plan.run.insert("max_force_evaluations",
                    run_sec.integer("max_force_evaluations", 0, 1000000000000000));
  plan.blocks = run_sec.integer("blocks", 20, 2, 100000);
  plan.run.insert("blocks", plan.blocks);
  run_sec.finish();

  // [prepare]: init = "FILE", or t = T with optional overrides.
  const toml::table* prep = top.get_as<toml::table>("prepare");
  if (!prep)
    throw ConfigError(where +
                      "no [prepare] section; allowed [prepare] t = T (a preparation run) "
                      "or init = \"FILE.xyz\"");
  {
    ConfigSection sec("prepare", prep);
    const bool has_init = sec.has("init"), has_t = sec.has("t");
    if (has_init == has_t)
      throw ConfigError(where + "[prepare] has " +
                        (has_init ? "both init and t"
                                  : "neither init "
                                    "nor t") +
                        "; allowed one of them");
    if (has_init) {
      fs::path p(sec.text("init", ""));
      if (p.is_relative())
        p = fs::path(base_dir.empty() ? "." : base_dir) / p;
      plan.init = fs::absolute(p).lexically_normal().string();
      if (plan.replicas > 1)
        throw ConfigError(where + "replicas = " + std::to_string(plan.replicas) +
                          " with [prepare] init: the dynamics is deterministic, so runs from "
                          "one start state are identical; allowed replicas = 1, or [prepare] "
                          "t = T (one preparation per replica)");
      if (prep->size() > 1)
        throw ConfigError(where + "[prepare] init with other keys; allowed init alone");
    } else {
      plan.prepare_t = sec.number("t", Range::positive());
      if (sec.has("sample_every"))
        plan.prepare_sample_every = sec.number("sample_every", Range::positive());
      plan.prepare_overrides =
          read_overrides(*prep, source + ": [prepare]", {"t", "sample_every"}, false);
    }
  }

  // [[setting]]
  const toml::node* settings = top.get("setting");
  const toml::array* list = settings ? settings->as_array() : nullptr;
  if (!list || list->empty() || !list->is_array_of_tables())
    throw ConfigError(where +
                      "no [[setting]] tables; allowed at least two [[setting]] with a "
                      "label each");
  for (const auto& node : *list) {
    const toml::table& t = *node.as_table();
    CompareSetting s;
    const auto label = t.get("label") ? t.get("label")->value<std::string>() : std::nullopt;
    const std::string at = where + "[[setting]] " + std::to_string(plan.settings.size() + 1);
    if (!label || !valid_label(*label))
      throw ConfigError(at + ": label = " + (t.get("label") ? show(*t.get("label")) : "missing") +
                        "; allowed 1-64 characters of A-Z a-z 0-9 _ - . + =");
    s.label = *label;
    for (const auto& other : plan.settings)
      if (other.label == s.label)
        throw ConfigError(at + ": label \"" + s.label + "\" given twice; allowed unique labels");
    s.overrides = read_overrides(t, where + "[[setting]] '" + s.label + "'",
                                 {"label", "start", "from", "converged"}, true);
    if (const toml::node* c = t.get("converged")) {
      if (!c->is_boolean())
        throw ConfigError(where + "[[setting]] '" + s.label + "': converged = " + show(*c) +
                          "; allowed true or false");
      s.converged = c->as_boolean()->get();
    }
    if (const toml::node* st = t.get("start")) {
      const auto v = st->value<std::string>();
      if (!v || (*v != "final" && *v != "mean_phi"))
        throw ConfigError(where + "[[setting]] '" + s.label + "': start = " + show(*st) +
                          "; allowed \"final\" (the source's state as it ended) or "
                          "\"mean_phi\" (dilated to the source's mean phi)");
      s.start_mean_phi = *v == "mean_phi";
    }
    if (const toml::node* f = t.get("from")) {
      const auto v = f->value<std::string>();
      if (!v)
        throw ConfigError(where + "[[setting]] '" + s.label + "': from = " + show(*f) +
                          "; allowed the label of an earlier [[setting]]");
      s.from = *v;
    }
    plan.settings.push_back(std::move(s));
  }
  if (plan.settings.size() < 2)
    throw ConfigError(where + "one [[setting]]; allowed at least two (a reference and another)");
  const toml::node* ref = top.get("reference");
  const auto ref_label = ref ? ref->value<std::string>() : std::nullopt;
  std::vector<std::string> labels;
  for (const auto& s : plan.settings)
    labels.push_back(s.label);
  const auto it = ref_label ? std::find(labels.begin(), labels.end(), *ref_label) : labels.end();
  if (it == labels.end())
    throw ConfigError(where + "reference = " + (ref ? show(*ref) : "missing") +
                      "; allowed the label of a setting: " + join(labels));
  plan.reference = static_cast<std::size_t>(it - labels.begin());

  for (auto& s : plan.settings) {
    if (s.from.empty())
      continue;
    const auto src = std::find(labels.begin(), labels.end(), s.from);
    const auto idx = static_cast<std::size_t>(&s - plan.settings.data());
    if (src == labels.end() || std::size_t(src - labels.begin()) >= idx)
      throw ConfigError(where + "[[setting]] '" + s.label + "': from = \"" + s.from +
                        "\"; allowed the label of an earlier [[setting]]: " +
                        join(std::vector<std::string>(labels.begin(), labels.begin() + idx)));
    s.from_index = static_cast<std::size_t>(src - labels.begin());
    const CompareSetting& source = plan.settings[s.from_index];
    if (!source.from.empty())
      throw ConfigError(where + "[[setting]] '" + s.label + "': from = \"" + s.from +
                        "\", which itself continues from '" + source.from +
                        "'; allowed a setting that starts from the preparation");
  }

  const toml::node* case_node = top.get("case");
  if (!case_node) {
    check_plan(plan, where);
    return plan;
  }
  const toml::array* case_list = case_node->as_array();
  if (!case_list || case_list->empty() || !case_list->is_array_of_tables())
    throw ConfigError(where + "case = " + show(*case_node) +
                      "; allowed [[case]] tables with a label each");
  for (const auto& node : *case_list) {
    const toml::table& t = *node.as_table();
    const auto label = t.get("label") ? t.get("label")->value<std::string>() : std::nullopt;
    const std::string at = where + "[[case]] " + std::to_string(plan.cases.size() + 1);
    if (!label || !valid_label(*label))
      throw ConfigError(at + ": label = " + (t.get("label") ? show(*t.get("label")) : "missing") +
                        "; allowed 1-64 characters of A-Z a-z 0-9 _ - . + =");
    for (const auto& other : plan.cases)
      if (other.label == *label)
        throw ConfigError(at + ": label \"" + *label + "\" given twice; allowed unique labels");
    plan.cases.push_back(case_plan(plan, t, *label, where + "[[case]] '" + *label + "': "));
  }
  return plan;
}

namespace {

// The checks that need the whole plan (a case's, or the file's without cases): every setting's
// N, what start = "mean_phi" and from need, and every scene through the checks of `jamflow run`,
// before anything runs.
void check_plan(ComparePlan& plan, const std::string& where) {
  const std::int64_t base_n = scene_n(plan.base);
  for (auto& s : plan.settings) {
    s.n = base_n;
    if (const toml::table* sys = s.overrides.get_as<toml::table>("system"))
      if (const toml::node* n = sys->get("N"); n && n->is_integer())
        s.n = n->as_integer()->get();
    if (!plan.init.empty() && s.n != base_n)
      throw ConfigError(where + "[[setting]] '" + s.label +
                        "' sets system.N with [prepare] init; allowed N from the start state");
  }
  for (const auto& s : plan.settings) {
    if (!s.from.empty() && plan.settings[s.from_index].n != s.n)
      throw ConfigError(where + "[[setting]] '" + s.label + "': from = \"" + s.from +
                        "\" with N = " + std::to_string(s.n) + " against its " +
                        std::to_string(plan.settings[s.from_index].n) + "; allowed the same N");
  }
  // Every scene through the checks of `jamflow run`, before anything runs.
  for (std::size_t s = 0; s < plan.settings.size(); ++s) {
    try {
      (void)parse_run_spec(plan.setting_scene(s));
    } catch (const ConfigError& e) {
      throw ConfigError(where + "[[setting]] '" + plan.settings[s].label + "': " + e.what());
    }
  }
  for (const auto& s : plan.settings) {
    if (!s.start_mean_phi)
      continue;
    if (!plan.init.empty() && s.from.empty())
      throw ConfigError(where + "[[setting]] '" + s.label +
                        "': start = \"mean_phi\" with [prepare] init; allowed with a "
                        "preparation run ([prepare] t) or from = a setting, whose mean phi it "
                        "takes");
    const auto idx = static_cast<std::size_t>(&s - plan.settings.data());
    if (plan.setting_scene(idx).section("ensemble").text("kind", "") != "constant_volume")
      throw ConfigError(where + "[[setting]] '" + s.label +
                        "': start = \"mean_phi\" at constant pressure; allowed for a "
                        "constant-volume setting (the piston sets phi otherwise)");
  }

  if (plan.init.empty()) {
    for (std::int64_t n : plan.sizes()) {
      try {
        (void)parse_run_spec(plan.prepare_scene(n));
      } catch (const ConfigError& e) {
        throw ConfigError(where + "[prepare] (N = " + std::to_string(n) + "): " + e.what());
      }
    }
  }
}

// A case's `settings = ["label", ...]`: only those settings run in it (the reference and the
// settings others continue from among them), in the file's order.
void select_settings(ComparePlan& c, const toml::node& v, const std::string& where) {
  const toml::array* a = v.as_array();
  std::vector<std::string> labels;
  for (const auto& s : c.settings)
    labels.push_back(s.label);
  if (!a || a->empty())
    throw ConfigError(where + "settings = " + show(v) +
                      "; allowed a list of setting labels: " + join(labels));
  std::vector<bool> keep(c.settings.size(), false);
  for (const auto& x : *a) {
    const auto label = x.value<std::string>();
    const auto it = label ? std::find(labels.begin(), labels.end(), *label) : labels.end();
    if (it == labels.end())
      throw ConfigError(where + "settings: " + show(x) + " is not a setting; allowed " +
                        join(labels));
    keep[std::size_t(it - labels.begin())] = true;
  }
  std::vector<std::size_t> new_index(c.settings.size(), 0);
  std::vector<CompareSetting> kept;
  for (std::size_t i = 0; i < c.settings.size(); ++i) {
    if (!keep[i])
      continue;
    const CompareSetting& s = c.settings[i];
    if (!s.from.empty() && !keep[s.from_index])
      throw ConfigError(where + "settings: '" + s.label + "' continues from '" + s.from +
                        "', which is not among them; allowed both");
    new_index[i] = kept.size();
    kept.push_back(s);
  }
  if (!keep[c.reference])
    throw ConfigError(where + "settings: the reference '" + labels[c.reference] +
                      "' is not among them; allowed a list with the reference");
  for (auto& s : kept)
    if (!s.from.empty())
      s.from_index = new_index[s.from_index];
  c.reference = new_index[c.reference];
  c.settings = std::move(kept);
}

// One [[case]]: the plan with the case's state point (system.N, phi, alpha; ensemble.*;
// shear.rate) over the base, and its own [run] lengths and [prepare] t, checked whole.
ComparePlan case_plan(const ComparePlan& plan, const toml::table& t, const std::string& label,
                      const std::string& where) {
  ComparePlan c = plan;
  c.cases.clear();
  c.label = label;
  c.name = plan.name + "/" + label;
  // reference = "LABEL": the case's own reference (a stiff state point needs a smaller step);
  // read before `settings`, which must keep it.
  if (const toml::node* r = t.get("reference")) {
    const auto label = r->value<std::string>();
    std::size_t idx = c.settings.size();
    for (std::size_t i = 0; i < c.settings.size() && label; ++i)
      if (c.settings[i].label == *label)
        idx = i;
    if (idx == c.settings.size()) {
      std::vector<std::string> labels;
      for (const auto& s : c.settings)
        labels.push_back(s.label);
      throw ConfigError(where + "reference = " + show(*r) +
                        "; allowed the label of a setting: " + join(labels));
    }
    c.reference = idx;
  }
  toml::table base;
  for (const auto& [k, v] : t) {
    const std::string section(k.str());
    if (section == "label" || section == "reference")
      continue;
    if (section == "settings") {
      select_settings(c, v, where);
      continue;
    }
    const toml::table* keys = v.as_table();
    static const std::vector<std::string> kSections = {"system", "ensemble", "shear", "run",
                                                       "prepare"};
    if (!keys || std::find(kSections.begin(), kSections.end(), section) == kSections.end())
      throw ConfigError(where + "key " + section + " = " + show(v) +
                        "; allowed label, reference, settings and the tables " + join(kSections));
    if (section == "prepare" && !plan.init.empty())
      throw ConfigError(where + "[prepare] with [prepare] init = \"" + plan.init +
                        "\"; allowed with a preparation run ([prepare] t)");
    if (section == "run" || section == "prepare") {
      try {
        ConfigSection sec(section, keys);
        if (section == "run") {
          for (const char* key : {"t_eq", "t_av", "sample_every"})
            if (sec.has(key))
              c.run.insert_or_assign(
                  key, sec.number(key, std::string(key) == "t_eq" ? Range::non_negative()
                                                                  : Range::positive()));
          // A budget per run in force evaluations: per particle-step budgets differ with N.
          if (sec.has("max_force_evaluations"))
            c.run.insert_or_assign("max_force_evaluations",
                                   sec.integer("max_force_evaluations", 0, 1000000000000000));
          sec.finish();
        } else {
          if (sec.has("t"))
            c.prepare_t = sec.number("t", Range::positive());
          if (sec.has("sample_every"))
            c.prepare_sample_every = sec.number("sample_every", Range::positive());
          // Its other keys override the preparation's scene, over the file's [prepare]: a stiff
          // state point prepared at a smaller step, say.
          const toml::table o = read_overrides(*keys, "prepare", {"t", "sample_every"}, false);
          for (const auto& [sec_name, node] : o) {
            const toml::table& add = *node.as_table();
            toml::table* into = c.prepare_overrides.get_as<toml::table>(sec_name.str());
            const toml::node* kind = add.get("kind");
            const toml::node* old_kind = into ? into->get("kind") : nullptr;
            if (!into || (kind && (!old_kind || show(*kind) != show(*old_kind)))) {
              c.prepare_overrides.insert_or_assign(sec_name.str(), add);
              continue;
            }
            for (const auto& [k, v] : add)
              into->insert_or_assign(k.str(), v);
          }
        }
      } catch (const ConfigError& e) {
        throw ConfigError(where + e.what());
      }
    } else {
      for (const auto& [k2, v2] : *keys) {
        const std::string key(k2.str());
        const bool allowed = section == "ensemble" || (section == "shear" && key == "rate") ||
                             (section == "system" &&
                              (key == "N" || key == "phi" || key == "alpha" || key == "skin"));
        if (!allowed)
          throw ConfigError(where + "key " + section + "." + key + " = " + show(v2) +
                            "; allowed system.N, system.phi, system.alpha, system.skin, "
                            "ensemble.*, shear.rate, run.t_eq, run.t_av, run.sample_every, "
                            "run.max_force_evaluations, prepare.t, prepare.sample_every and "
                            "the preparation's overrides");
      }
      base.insert(section, *keys);
    }
  }
  apply_overrides(c.base, base);
  if (!plan.init.empty() && base.contains("system"))
    throw ConfigError(where +
                      "system.* with [prepare] init; allowed N and phi from the start "
                      "state");
  check_plan(c, where);
  return c;
}

}  // namespace

ComparePlan load_compare(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::error_code ec;
  if (!in || fs::is_directory(path, ec))
    throw InputFileError("cannot read compare file '" + path + "'; allowed a readable TOML file");
  std::ostringstream buf;
  buf << in.rdbuf();
  return parse_compare(buf.str(), path, fs::path(path).parent_path().string());
}

ComparePlan study_compare_plan(const std::string& study, const std::string& preset) {
  const fs::path dir = fs::path(studies_data_dir()) / study;
  const fs::path file = dir / (preset + ".toml");
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) {
    std::vector<std::string> presets;
    for (const auto& e : fs::directory_iterator(dir, ec))
      if (e.path().extension() == ".toml")
        presets.push_back(e.path().stem().string());
    std::sort(presets.begin(), presets.end());
    throw ConfigError("--preset " + preset + "; allowed " + join(presets));
  }
  ComparePlan plan = load_compare(file.string());
  plan.name = plan.study = study;  // its stages and report are the study's
  return plan;
}

}  // namespace jamflow::studies
