/**
 * @file web_page.h
 * @brief The browser viewer's page (web/) as a WebSite, read once: index.html, app.js, style.css, and three.js
 *        from web/node_modules (installed by `npm ci`, which scripts/setup.sh runs).
 */
#pragma once

#include <string>
#include <vector>

#include "xpersif/core/web/web_server.h"

namespace xpersif::core {

/**
 * @brief The page's files under @p web_root, by the paths the page asks for ("/", "/app.js", "/three/...");
 *        "/favicon.ico" is answered 204. A file that cannot be read is answered 503 with a sentence that names
 *        it and what to do; @p missing gets its path.
 */
WebSite viewerSite(const std::string& web_root, std::vector<std::string>& missing);

}  // namespace xpersif::core
