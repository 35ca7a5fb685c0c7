#pragma once
// Pieces of the self-contained HTML pages flatscan writes (the station report, the
// evaluate study's report): nothing in them is fetched, so a page opens the same on a
// factory PC without internet, from a USB stick or as an e-mail attachment.
#include <string>

namespace flatscan {

// Text with &, <, >, " and ' escaped for HTML.
std::string HtmlEscape(const std::string& text);

// "data:<mime>;base64,<bytes in base64>": an image inside the page (OpenSSL's encoder).
std::string DataUri(const std::string& mime, const std::string& bytes);

// The style sheet both reports use (screen and print).
const char* ReportStyle();

// A whole page: <title> and <h1> `title` (escaped), the style sheet, then `body_html`.
std::string HtmlPage(const std::string& title, const std::string& body_html);

// CommonMark with GitHub's table extension to HTML (cmark-gfm, Debian libcmark-gfm-dev).
// Raw HTML in the text is not passed through (cmark's safe mode): a study's text cannot
// inject markup.
std::string MarkdownToHtml(const std::string& markdown);

}  // namespace flatscan
