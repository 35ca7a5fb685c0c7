#include "flatscan/report/html_page.h"

#include <cstdlib>
#include <memory>
#include <mutex>
#include <stdexcept>

#include <cmark-gfm-core-extensions.h>
#include <cmark-gfm.h>
#include <openssl/evp.h>

namespace flatscan {

std::string HtmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string DataUri(const std::string& mime, const std::string& bytes) {
  std::string base64(4 * ((bytes.size() + 2) / 3) + 1, '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(base64.data()),
                                reinterpret_cast<const unsigned char*>(bytes.data()), int(bytes.size()));
  base64.resize(size_t(n));
  return "data:" + mime + ";base64," + base64;
}

const char* ReportStyle() {
  return "body{font-family:sans-serif;margin:24px;color:#222}h1{font-size:22px}h2{font-size:18px;margin-top:28px}"
         "table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #ccc;padding:3px 8px;text-align:left}"
         "th{background:#f2f2f2}.num{text-align:right}.fail{color:#c00;font-weight:bold}.note{color:#555;font-size:12px}"
         "code{background:#f4f4f4;padding:1px 4px}img{max-width:100%}"
         // Printed (--pdf): A4, each recipe from the top of a page, no table or chart cut in two.
         // Smaller type and charts on paper: a recipe with a few listed parts fits one page (ten
         // worst and ten not-measured parts take two).
         "@page{size:A4;margin:12mm}@media print{body{margin:0;font-size:10pt}h2{margin-top:8px}td,th{padding:1px 5px}"
         "svg{height:115px;width:auto}.recipe{break-before:page}table,svg,img{break-inside:avoid}}";
}

std::string HtmlPage(const std::string& title, const std::string& body_html) {
  return "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" + HtmlEscape(title) +
         "</title><style>" + ReportStyle() + "</style></head><body>\n<h1>" + HtmlEscape(title) + "</h1>\n" + body_html +
         "</body></html>\n";
}

std::string MarkdownToHtml(const std::string& markdown) {
  static std::once_flag registered;
  std::call_once(registered, [] { cmark_gfm_core_extensions_ensure_registered(); });
  const auto free_parser = [](cmark_parser* p) { cmark_parser_free(p); };
  std::unique_ptr<cmark_parser, decltype(free_parser)> parser(cmark_parser_new(CMARK_OPT_DEFAULT), free_parser);
  cmark_syntax_extension* table = cmark_find_syntax_extension("table");
  if (!table || !cmark_parser_attach_syntax_extension(parser.get(), table))
    throw std::runtime_error("cmark-gfm: the table extension is missing");
  cmark_parser_feed(parser.get(), markdown.data(), markdown.size());
  const auto free_node = [](cmark_node* n) { cmark_node_free(n); };
  std::unique_ptr<cmark_node, decltype(free_node)> document(cmark_parser_finish(parser.get()), free_node);
  char* html = cmark_render_html(document.get(), CMARK_OPT_DEFAULT, cmark_parser_get_syntax_extensions(parser.get()));
  std::string out(html);
  cmark_get_default_mem_allocator()->free(html);
  return out;
}

}  // namespace flatscan
