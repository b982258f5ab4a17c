/**
 * @file latest_features.h
 * @brief The newest feature vector a perception component produced, and its get_features operation:
 *        OBSERVATION, PERCEPTION, FEATUREEXTRACTION and VISION all offer the same one, so it is written once.
 *        Thread-safe.
 */
#pragma once

#include <mutex>
#include <string>

#include "xpersif/FeatureVector.h"
#include "xpersif/GetFeatures.h"
#include "xpersif/component/component.h"
#include "xpersif/core/common/contract.h"

namespace xpersif {

class LatestFeatures {
 public:
  void set(FeatureVector::ConstPtr features);
  void reset() { set(nullptr); }
  FeatureVector::ConstPtr get() const;

  /// get_features' contract: "the latest feature vector from @p source"; @p not_yet is the sentence for a call
  /// that comes before the first vector.
  core::ContractChecker<GetFeatures::Request> contract(const std::string& source, const std::string& not_yet) const;
  /// The request's check (max_age finite and non-negative). @throws core::ValidationError
  static void validate(const GetFeatures::Request& request);
  /// ~invoke's binder of get_features: the setting max_age (s, 0: any age; default 0); the report adds the vector
  /// to the invoke result's features.
  static Binder<GetFeatures::Request, GetFeatures::Response> binder();
  /// The latest vector, unless it is older than request.max_age. @throws std::runtime_error
  void answer(const GetFeatures::Request& request, GetFeatures::Response& response) const;

 private:
  mutable std::mutex mutex_;
  FeatureVector::ConstPtr latest_;
};

}  // namespace xpersif
