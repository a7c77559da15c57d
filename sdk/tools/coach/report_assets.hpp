// What the lesson report is made of, compiled into the CLI at build time (cmake/EmbedFiles.cmake)
// so that `kata coach` writes a self-contained report from anywhere: the page's Mustache template
// (coach/report.html.mustache) and uPlot, the chart library (npm "uplot", pinned by
// viewer/package-lock.json). Without npm at build time the uPlot strings are empty and the report
// says its charts are missing.
#pragma once

namespace kata::coach::report_assets {

extern const char kReportTemplate[];
extern const char kUplotJs[];       // dist/uPlot.iife.min.js
extern const char kUplotCss[];      // dist/uPlot.min.css
extern const char kUplotLicense[];  // its LICENSE (MIT), carried in the report
extern const char kUplotVersion[];  // "1.6.32"

}  // namespace kata::coach::report_assets
