#include "xpersif/perception/latest_features.h"

#include "xpersif/core/common/validation.h"

namespace xpersif {

void LatestFeatures::set(FeatureVector::ConstPtr features) {
  std::lock_guard<std::mutex> lock(mutex_);
  latest_ = std::move(features);
}

FeatureVector::ConstPtr LatestFeatures::get() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return latest_;
}

core::ContractChecker<GetFeatures::Request> LatestFeatures::contract(const std::string& source,
                                                                     const std::string& not_yet) const {
  core::Contract c;
  c.name = "get_features";
  c.kind = core::Contract::Kind::Operation;
  c.interface_type = "xpersif/GetFeatures";
  c.description = "the latest feature vector from " + source;
  c.preconditions = {{"perceived(scene)", "a feature vector must have been produced"}};
  c.effects = {"observed(scene)"};
  core::ContractChecker<GetFeatures::Request> checker(c);
  checker.check("perceived(scene)",
                [this, not_yet](const GetFeatures::Request&) { return get() ? std::string() : not_yet; });
  return checker;
}

void LatestFeatures::validate(const GetFeatures::Request& request) {
  core::requireInRange("max_age", request.max_age, 0.0, 1e6);
}

Binder<GetFeatures::Request, GetFeatures::Response> LatestFeatures::binder() {
  return {[](const core::Invocation& invocation) {
            GetFeatures::Request request;
            request.max_age = invocation.settingNumber("max_age", 0.0, 0.0, 1e6);
            return request;
          },
          [](const GetFeatures::Response& response, InvokeResult& out) {
            out.features.push_back(response.features);
          }};
}

void LatestFeatures::answer(const GetFeatures::Request& request, GetFeatures::Response& response) const {
  const FeatureVector::ConstPtr latest = get();
  if (!latest) throw std::runtime_error("no feature vector yet");
  if (request.max_age > 0) {
    const double age = (ros::Time::now() - latest->header.stamp).toSec();
    if (age > request.max_age) {
      throw std::runtime_error("the latest feature vector is " + core::describeNumber(age) + " s old, more than max_age " +
                               core::describeNumber(request.max_age) + " s");
    }
  }
  response.features = *latest;
}

}  // namespace xpersif
