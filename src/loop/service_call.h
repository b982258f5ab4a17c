/**
 * @file service_call.h
 * @brief LOOPMODEL's calls of other components' services from the run's thread: once (call), patient with a
 *        component that is being restarted or not active yet (callPatiently), and patient also with an unmet
 *        precondition that a component just (re)started may not meet yet (callWhenReady).
 */
#pragma once

#include <ros/ros.h>

#include <cstdint>
#include <functional>
#include <string>

#include "xpersif/ResultCode.h"

namespace xpersif {
namespace loop {

/// Call a service of another component from the loop's own thread; "" or why it failed, with the outcome's
/// xpersif/ResultCode in @p code (UNAVAILABLE when the service is not offered or does not answer).
template <class Service>
std::string call(ros::NodeHandle& nh, const std::string& name, Service& service, std::uint8_t* code = nullptr) {
  const std::string resolved = nh.resolveName(name);
  std::uint8_t ignored = 0;
  std::uint8_t& result = code ? *code : ignored;
  result = ResultCode::UNAVAILABLE;
  if (!ros::service::waitForService(resolved, ros::Duration(10.0))) return "service " + resolved + " is not offered";
  if (!ros::service::call(resolved, service)) return "service " + resolved + " did not answer";
  result = service.response.code;
  if (!service.response.success) return resolved + ": " + service.response.message;
  return "";
}

/// The same, patient with a component that is being restarted (LOOPMODEL brings it back) or not ready yet:
/// retries while the answer is UNAVAILABLE or NOT_ACTIVE (and, with @p unmet_too, PRECONDITION_FAILED: the PLANNER
/// still reading contracts, DESIGNOFEXPERIMENTS before its first feature vector), for up to @p patience seconds
/// or until @p stop says so.
/// The last answer's code goes to @p code_out when given.
template <class Service>
std::string callPatiently(ros::NodeHandle& nh, const std::string& name, Service& service, double patience = 60.0,
                          bool unmet_too = false, const std::function<bool()>& stop = {},
                          std::uint8_t* code_out = nullptr) {
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(patience);
  std::uint8_t ignored = ResultCode::OK;
  std::uint8_t& code = code_out ? *code_out : ignored;
  std::string why = call(nh, name, service, &code);
  while (!why.empty() && ros::ok() && ros::WallTime::now() < until && !(stop && stop()) &&
         (code == ResultCode::UNAVAILABLE || code == ResultCode::NOT_ACTIVE ||
          (unmet_too && code == ResultCode::PRECONDITION_FAILED))) {
    ros::WallDuration(0.2).sleep();
    why = call(nh, name, service, &code);
  }
  return why;
}

/// Patient also with an unmet precondition, which a component just (re)started may not meet yet.
template <class Service>
std::string callWhenReady(ros::NodeHandle& nh, const std::string& name, Service& service,
                          const std::function<bool()>& stop, std::uint8_t* code = nullptr) {
  return callPatiently(nh, name, service, 60.0, true, stop, code);
}

/// The name of an xpersif/ResultCode value, as ResultCode.msg spells it.
inline std::string resultCodeName(std::uint8_t code) {
  switch (code) {
    case ResultCode::OK: return "OK";
    case ResultCode::NOT_ACTIVE: return "NOT_ACTIVE";
    case ResultCode::INVALID: return "INVALID";
    case ResultCode::PRECONDITION_FAILED: return "PRECONDITION_FAILED";
    case ResultCode::UNAVAILABLE: return "UNAVAILABLE";
    case ResultCode::FAILED: return "FAILED";
    default: return "code " + std::to_string(code);
  }
}

}  // namespace loop
}  // namespace xpersif
