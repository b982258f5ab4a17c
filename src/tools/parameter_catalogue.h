/**
 * @file parameter_catalogue.h
 * @brief Every component type's declared parameters (core/parameters.h), in one list: what the parameter reference
 *        (doc/parameters.md) is generated from (xpersif_parameters) and what experiment files are checked against
 *        (xpersif_experiment).
 */
#pragma once

#include <string>
#include <vector>

#include "xpersif/core/common/parameters.h"

namespace xpersif {

struct ComponentParameters {
  std::string heading;  ///< the paper's name or the component's role, e.g. "DESIGNOFEXPERIMENTS"
  std::string type;     ///< the nodelet type, e.g. "xpersif/DesignOfExperimentsNodelet" ("" for every component's)
  const core::ParameterTable* table;
};

/// The base's parameters first (type ""), then every component type of this package.
const std::vector<ComponentParameters>& parameterCatalogue();

/// The declared parameters of a component @p type, its own and the base's; nullptr for a type not in the catalogue.
const core::ParameterTable* declaredParametersOf(const std::string& type);

}  // namespace xpersif
