#pragma once
// Where the CLI finds what it ships with: the default model, the default lesson's clips, the
// viewer and the schemas. They live under share/kata beside the executable's bin/ in both
// layouts, so `kata` works from any directory:
//   build tree:  build/bin/kata   -> build/share/kata/{models,data/cmu,viewer}   (copied at build time)
//   installed:   PREFIX/bin/kata  -> PREFIX/share/kata/{models,data/cmu,viewer,schemas}
#include <string>

namespace kata::cli {

// PREFIX/share/kata for the running executable (from /proc/self/exe); "share/kata" if unknown.
std::string share_dir();

// A default file named relative to the checkout (e.g. "models/default.kata"): that path when it
// exists from the current directory (running from the repository root, as the README does),
// otherwise share_dir()/relative when that exists, otherwise `relative` unchanged so that the
// error that follows names the file the user expected (and "" stays ""). The commands apply it to
// their input files too, so the docs' `data/cmu/...` and `models/...` work from an install.
std::string default_data_file(const std::string& relative);

// The installed user documentation's page (e.g. "config.md", "model/transition.md"):
// PREFIX/share/doc/kata/PAGE beside share_dir(), where `cmake --install` puts docs/ (and the build
// copies it to build/share/doc/kata), so `kata <cmd> --help` names a file the user has.
std::string doc_file(const std::string& page);

}  // namespace kata::cli
