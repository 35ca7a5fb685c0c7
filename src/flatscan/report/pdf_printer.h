#pragma once
// A report as PDF: headless Chromium (Debian's `chromium`) prints the HTML file, so that the
// PDF is the page a supervisor sees in a browser, with the same inline SVG charts. No
// library in Debian renders HTML with CSS to PDF; Chromium is already the station's browser
// for the tests.
#include <filesystem>
#include <string>

namespace flatscan {

struct PdfPrintOptions {
  std::string chromium = "chromium";  // the program (searched in PATH), or its path
  double timeout_s = 120;             // then Chromium and its children are killed
};

// Prints the page `html` (the text of a self-contained HTML file) to `pdf` (A4, no header
// or footer). Chromium runs in its own process group with a private temporary folder for
// the page and its profile (removed afterwards), and with --no-sandbox
// only when run as root (Chromium refuses root otherwise). Throws std::runtime_error
// saying what failed (Chromium not found, its exit status with the last lines it printed,
// the time limit, a file that is no PDF). Returns the number of pages printed.
int PrintHtmlToPdf(const std::string& html, const std::filesystem::path& pdf, const PdfPrintOptions& options = {});

// The number of pages of a PDF file's bytes (its page objects: "/Type /Page"), 0 for
// bytes that are no PDF.
int PdfPageCount(const std::string& pdf_bytes);

}  // namespace flatscan
