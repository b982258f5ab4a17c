#include "xpersif/perception/feature_selection.h"

#include "xpersif/component/parameters.h"

namespace xpersif {

namespace {
std::string joined(const std::vector<std::string>& names) {
  std::string text;
  for (const auto& n : names) text += (text.empty() ? "" : ", ") + n;
  return text;
}
}  // namespace

FeatureSelection::FeatureSelection(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/FeatureSelectionNodelet") {
  core::Contract select;
  select.name = "select_features";
  select.kind = core::Contract::Kind::Operation;
  select.interface_type = "xpersif/SelectFeatures";
  select.description = "choose the further features VISION computes (empty: the defaults)";
  select.parameters = {"?names"};
  select.preconditions = {{"available(?names)", "every name must be one of the available features"}};
  select.effects = {"selected(?names)"};
  ContractChecker<SelectFeatures::Request> contract(select);
  contract.bind([](const SelectFeatures::Request& r) { return core::Bindings{{"?names", "[" + joined(r.names) + "]"}}; })
      .check("available(?names)", [](const SelectFeatures::Request& r) {
        if (r.names.empty()) return std::string();
        try {
          core::FeatureSelection probe(r.names);
        } catch (const std::exception& e) {
          return std::string(e.what());
        }
        return std::string();
      });
  addOperation<SelectFeatures>(
      contract, [](const SelectFeatures::Request& r) { core::requireMaxSize("names", r.names.size(), 64); },
      [this](const SelectFeatures::Request& request, SelectFeatures::Response& response) {
        {
          std::lock_guard<std::mutex> lock(mutex_);
          if (request.names.empty()) {
            selection_.reset();
          } else {
            selection_.set(request.names);
          }
          response.selected = selection_.names();
        }
        publish();
      },
      false);
}

const core::ParameterTable& FeatureSelection::parameters() {
  static const core::ParameterTable table(
      "feature_selection",
      {core::namesParameter("features", core::FeatureSelection::defaultNames(), 64,
                            "the features VISION computes at first (names from ~available)"),
       core::outputParameter(core::ParameterSpec::Type::StringList, "available",
                             "the features one can choose, \"name [unit]: description\"")});
  return table;
}

void FeatureSelection::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, FeatureSelection::parameters());
  core::FeatureSelection selection;
  // An unknown name throws with the list of known ones: configure fails.
  if (parameters.has("features")) selection.set(parameters.get<std::vector<std::string>>("features"));
  std::vector<std::string> available;
  for (const auto& f : core::availableFeatures()) available.push_back(f.name + " [" + f.unit + "]: " + f.description);
  pnh.setParam("available", available);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    selection_ = selection;
    if (!selection_pub_) selection_pub_ = pnh.advertise<FeatureNames>("selection", 1, true);
  }
  publish();
}

void FeatureSelection::publish() {
  FeatureNames message;
  std::lock_guard<std::mutex> lock(mutex_);
  message.names = selection_.names();
  selection_pub_.publish(message);
}

}  // namespace xpersif
