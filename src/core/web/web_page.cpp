#include "xpersif/core/web/web_page.h"

#include <fstream>
#include <sstream>
#include <tuple>

namespace xpersif::core {

namespace {

bool readFile(const std::string& path, std::string& out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream s;
  s << in.rdbuf();
  out = s.str();
  return static_cast<bool>(in) || in.eof();
}

}  // namespace

WebSite viewerSite(const std::string& web_root, std::vector<std::string>& missing) {
  WebSite site;
  site.not_found = "not found: the bridge serves /, /app.js, /style.css, /three/... and /stats\n";
  const std::string modules = web_root + "/node_modules/three";
  const std::string js = "text/javascript; charset=utf-8";
  const std::vector<std::tuple<std::string, std::string, std::string>> files = {
      {"/", web_root + "/index.html", "text/html; charset=utf-8"},
      {"/index.html", web_root + "/index.html", "text/html; charset=utf-8"},
      {"/app.js", web_root + "/app.js", js},
      {"/style.css", web_root + "/style.css", "text/css; charset=utf-8"},
      {"/three/three.module.js", modules + "/build/three.module.js", js},
      {"/three/three.core.js", modules + "/build/three.core.js", js},
      {"/three/addons/controls/OrbitControls.js", modules + "/examples/jsm/controls/OrbitControls.js", js}};
  for (const auto& [path, file, type] : files) {
    WebAsset a;
    a.type = type;
    if (!readFile(file, a.body)) {
      missing.push_back(file);
      a.status = 503;
      a.type = "text/plain; charset=utf-8";
      a.body = "The web bridge cannot serve " + path + ": " + file + " is missing. " +
               (file.find("node_modules") != std::string::npos
                    ? "Run `npm ci` in " + web_root + " (bash scripts/setup.sh does it).\n"
                    : "Is ~web_root right?\n");
    }
    site.assets[path] = std::move(a);
  }
  site.assets["/favicon.ico"] = WebAsset{204, "image/x-icon", ""};  // none: no 404 in the browser's console
  return site;
}

}  // namespace xpersif::core
