#include "flatscan/report/html_page.h"

#include <gtest/gtest.h>

namespace flatscan {
namespace {

// A study's markdown: headings, a GitHub table (the studies' tables), emphasis; raw HTML
// in it is not passed through (cmark's safe mode leaves a comment in its place).
TEST(HtmlPage, MarkdownTablesBecomeHtmlAndRawHtmlDoesNot) {
  const std::string html = MarkdownToHtml("## Batch\n\n| part | error (um) |\n|---|---:|\n| 1 | 2.5 |\n\n**bold** "
                                          "<script>alert(1)</script>\n");
  EXPECT_NE(html.find("<h2>Batch</h2>"), std::string::npos) << html;
  EXPECT_NE(html.find("<table>"), std::string::npos) << html;
  EXPECT_NE(html.find("<th>part</th>"), std::string::npos) << html;
  EXPECT_NE(html.find("<td align=\"right\">2.5</td>"), std::string::npos) << html;
  EXPECT_NE(html.find("<strong>bold</strong>"), std::string::npos) << html;
  EXPECT_EQ(html.find("<script>"), std::string::npos) << html;
}

TEST(HtmlPage, DataUrisAndThePage) {
  EXPECT_EQ(DataUri("image/png", ""), "data:image/png;base64,");
  EXPECT_EQ(DataUri("image/png", "M"), "data:image/png;base64,TQ==");
  EXPECT_EQ(DataUri("image/jpeg", "\xff\xd8\xff JPEG"), "data:image/jpeg;base64,/9j/IEpQRUc=");
  const std::string page = HtmlPage("a <b> & c", "<p>x</p>\n");
  EXPECT_EQ(page.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(page.find("<title>a &lt;b&gt; &amp; c</title>"), std::string::npos);
  EXPECT_NE(page.find("<h1>a &lt;b&gt; &amp; c</h1>\n<p>x</p>\n</body></html>\n"), std::string::npos);
  EXPECT_EQ(HtmlEscape("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&#39;");
}

}  // namespace
}  // namespace flatscan
