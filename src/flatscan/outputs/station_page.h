#pragma once
// The station's web page (served at / by http_server.h): HTML, CSS and a script that polls
// /api/summary, all in one text (nothing fetched from elsewhere).
#include <string_view>

namespace flatscan {

std::string_view StationPageHtml();

}  // namespace flatscan
