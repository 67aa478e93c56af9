#pragma once
// `ringsim mser [--batch M] [FILE|-]`
// Reads a series (one number per line; blank lines and '#' comments skipped)
// and prints the MSER-M truncation as one JSON line (docs/STEADY_STATE.md).

#include <iosfwd>
#include <string>

namespace CLI {
class App;
}

namespace ringsim {

struct MserOptions {
  std::string input = "-";   // FILE, or "-" for standard input
  std::string batch = "5";   // validated by mser_main (so a bad value exits 1 naming --batch)
};

void add_mser_command(CLI::App& app, MserOptions& opt);
// Exit status: 0 ok, 1 usage or input error (one line on `err`, prefixed "ringsim mser: ").
int mser_main(const MserOptions& opt, std::istream& in, std::ostream& out, std::ostream& err);

}  // namespace ringsim
