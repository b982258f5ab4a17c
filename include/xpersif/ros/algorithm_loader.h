/**
 * @file algorithm_loader.h
 * @brief Algorithms chosen by name, as move_base loads `~base_global_planner`: a pluginlib ClassLoader for
 *        one of the core's algorithm interfaces (core::PushModel, core::ExperimentDesign, core::PlanSearch),
 *        with the refusal every component gives for an unknown name: a ValidationError whose sentence names the
 *        parameter and lists the declared classes.
 *
 * Classes are declared by any package that depends on xpersif and exports `<xpersif plugin="${prefix}/x.xml"/>`
 * (this package: push_model_plugins.xml, experiment_design_plugins.xml, plan_search_plugins.xml); see
 * doc/plugins.md. The loader must outlive every instance it made (their code lives in its libraries):
 * declare it before the members that hold them.
 */
#pragma once

#include <pluginlib/class_loader.hpp>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "xpersif/core/common/validation.h"

namespace xpersif {

/// "a, b, c"
inline std::string joinWithCommas(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

template <class Base>
class AlgorithmLoader {
 public:
  /// @param base_class the interface's name in the plugin XML ("xpersif::core::PushModel")
  /// @param kind what the classes are, for sentences ("push model")
  AlgorithmLoader(const std::string& base_class, std::string kind)
      : loader_("xpersif", base_class), kind_(std::move(kind)) {}

  /// Every class declared by an exported plugin XML, sorted.
  std::vector<std::string> declared() {
    std::vector<std::string> names = loader_.getDeclaredClasses();
    std::sort(names.begin(), names.end());
    return names;
  }

  /// "" when @p type is declared, else the sentence refusing it (naming @p parameter, listing the classes).
  std::string whyNot(const std::string& parameter, const std::string& type) {
    const std::vector<std::string> names = declared();
    if (std::find(names.begin(), names.end(), type) != names.end()) return "";
    return parameter + " is '" + type + "', which no package declares as a " + kind_ + "; declared: " +
           joinWithCommas(names);
  }

  /// A new instance of @p type. Throws core::ValidationError for an undeclared type (whyNot's sentence) or one
  /// whose library cannot be loaded (pluginlib's reason).
  std::shared_ptr<Base> create(const std::string& parameter, const std::string& type) {
    const std::string why = whyNot(parameter, type);
    if (!why.empty()) throw core::ValidationError(why);
    try {
      return loader_.createSharedInstance(type);
    } catch (const pluginlib::PluginlibException& e) {
      throw core::ValidationError(parameter + " is '" + type + "', a declared " + kind_ +
                                  " that could not be loaded: " + e.what());
    }
  }

 private:
  pluginlib::ClassLoader<Base> loader_;
  std::string kind_;
};

}  // namespace xpersif
