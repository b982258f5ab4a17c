// libxpersif_bind_address.so: an LD_PRELOAD library that makes a process's wildcard listeners bind to one
// address, XPERSIF_BIND_ADDRESS, instead of every address of the host (doc/security.md).
//
// Why a preload library: ROS 1 has no setting for where it listens. xmlrpcpp (the XML-RPC server of every
// roscpp node and nodelet manager) always binds INADDR_ANY; roscpp's TCPROS server, rospy's servers, the
// master and roslaunch bind INADDR_ANY whenever ROS_IP is not a loopback address. ROS_IP only chooses the
// address a node advertises. scripts/env.sh preloads this library into everything started from its shell
// (and scripts/xpersif_env_loader into every process of a remote <machine>), so every listener the project
// starts listens on the chosen address and nowhere else.
//
// XPERSIF_BIND_ADDRESS: an IPv4 or IPv6 address literal; unset, empty or "any": nothing changes.
// With an IPv4 address, 0.0.0.0 becomes that address and :: its IPv4-mapped form (::ffff:a.b.c.d);
// with an IPv6 address, :: becomes that address and 0.0.0.0 becomes 127.0.0.1. Binds to a specific address,
// to Unix sockets and to any other family are passed through untouched.
#include <arpa/inet.h>
#include <dlfcn.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace {

struct Config {
  bool active = false;
  bool is_v6 = false;
  in_addr v4{};
  in6_addr v6{};
};

Config load() {
  Config config;
  const char* text = std::getenv("XPERSIF_BIND_ADDRESS");
  if (text == nullptr || *text == '\0' || std::strcmp(text, "any") == 0) return config;
  if (inet_pton(AF_INET, text, &config.v4) == 1) {
    config.active = true;
  } else if (inet_pton(AF_INET6, text, &config.v6) == 1) {
    config.active = true;
    config.is_v6 = true;
  } else {
    std::fprintf(stderr,
                 "xpersif_bind_address: XPERSIF_BIND_ADDRESS is '%s', which is not an IPv4 or IPv6 address "
                 "literal (or 'any'); this process's listeners bind where they ask\n",
                 text);
  }
  return config;
}

const Config& config() {
  static const Config instance = load();
  return instance;
}

using BindFunction = int (*)(int, const sockaddr*, socklen_t);

BindFunction realBind() {
  static const BindFunction function = reinterpret_cast<BindFunction>(dlsym(RTLD_NEXT, "bind"));
  return function;
}

}  // namespace

extern "C" int bind(int fd, const sockaddr* address, socklen_t length) {
  const BindFunction real = realBind();
  if (real == nullptr) {
    errno = ENOSYS;
    return -1;
  }
  const Config& chosen = config();
  if (!chosen.active || address == nullptr) return real(fd, address, length);

  if (address->sa_family == AF_INET && length >= static_cast<socklen_t>(sizeof(sockaddr_in))) {
    sockaddr_in in{};
    std::memcpy(&in, address, sizeof in);
    if (in.sin_addr.s_addr != htonl(INADDR_ANY)) return real(fd, address, length);
    if (chosen.is_v6) {
      in.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    } else {
      in.sin_addr = chosen.v4;
    }
    return real(fd, reinterpret_cast<const sockaddr*>(&in), sizeof in);
  }
  if (address->sa_family == AF_INET6 && length >= static_cast<socklen_t>(sizeof(sockaddr_in6))) {
    sockaddr_in6 in6{};
    std::memcpy(&in6, address, sizeof in6);
    if (std::memcmp(&in6.sin6_addr, &in6addr_any, sizeof in6addr_any) != 0) return real(fd, address, length);
    if (chosen.is_v6) {
      in6.sin6_addr = chosen.v6;
    } else {
      std::memset(&in6.sin6_addr, 0, sizeof in6.sin6_addr);
      in6.sin6_addr.s6_addr[10] = 0xff;
      in6.sin6_addr.s6_addr[11] = 0xff;
      std::memcpy(&in6.sin6_addr.s6_addr[12], &chosen.v4, sizeof chosen.v4);
    }
    return real(fd, reinterpret_cast<const sockaddr*>(&in6), sizeof in6);
  }
  return real(fd, address, length);
}
