#include "analysis/mser_command.hpp"

#include <CLI/CLI.hpp>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <istream>
#include <nlohmann/json.hpp>
#include <ostream>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "analysis/mser.hpp"

namespace ringsim {
namespace {

// Input or usage error of the command: becomes one "ringsim mser: ..." line and exit status 1.
struct MserInputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

std::string_view trim(std::string_view s) {
  const char* ws = " \t\r\n\v\f";
  const auto b = s.find_first_not_of(ws);
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(ws);
  return s.substr(b, e - b + 1);
}

std::size_t parse_batch(const std::string& text) {
  const std::string_view s = trim(text);
  unsigned long long v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  const bool whole = ec == std::errc() && ptr == s.data() + s.size() && !s.empty();
  if (!whole || v < 1)
    throw MserInputError("--batch = " + text + (whole ? "" : " is not a valid integer") +
                         "; valid range: integer >= 1");
  return static_cast<std::size_t>(v);
}

// One number per line; blank lines and lines whose first non-blank character
// is '#' are skipped. std::from_chars: locale-independent, whole text must parse.
std::vector<double> read_series(std::istream& in, const std::string& name) {
  std::vector<double> y;
  std::string line;
  std::size_t lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    std::string_view s = trim(line);
    if (s.empty() || s.front() == '#') continue;
    std::string_view num = s;
    // from_chars rejects a leading '+'; strip it unless a second sign follows ("+-5" is no number).
    if (num.size() > 1 && num.front() == '+' && num[1] != '-' && num[1] != '+') num.remove_prefix(1);
    double v = 0.0;
    auto [ptr, ec] = std::from_chars(num.data(), num.data() + num.size(), v);
    if (ec == std::errc::result_out_of_range && ptr == num.data() + num.size()) {
      // from_chars leaves v unset out of range: an underflow (1e-400) is a
      // number, 0 or subnormal as strtod rounds it; an overflow is not finite.
      v = std::strtod(std::string(num).c_str(), nullptr);
      if (std::isfinite(v)) ec = std::errc();
    }
    if (ec != std::errc() || ptr != num.data() + num.size() || !std::isfinite(v)) {
      std::string shown(s.substr(0, 80));
      if (s.size() > 80) shown += "...";
      throw MserInputError(name + ":" + std::to_string(lineno) + ": cannot read \"" + shown +
                           "\" as a finite number (one number per line; blank lines and '#' comments are skipped)");
    }
    y.push_back(v);
  }
  if (in.bad()) throw MserInputError(name + ": read error after line " + std::to_string(lineno));
  return y;
}

}  // namespace

void add_mser_command(CLI::App& app, MserOptions& opt) {
  CLI::App* cmd = app.add_subcommand(
      "mser", "Steady-state truncation point of a series by MSER-M (White 1997; M = 5 gives MSER-5).");
  cmd->footer(
      "Input: one number per line; blank lines and lines starting with '#' are skipped.\n"
      "Output: one JSON line {\"truncation\": T, \"steady\": B, \"batches\": K, \"statistic\": S, \"n\": N}:\n"
      "  T = warm-up length in raw observations (a multiple of M), K = floor(N / M) batch means\n"
      "  (a trailing remainder of N mod M observations is dropped), steady = truncation batch d* <= K/2.\n"
      "Examples:\n"
      "  ringsim mser series.txt                 MSER-5 of a file\n"
      "  seq 100 -1 1 | ringsim mser --batch 1   plain MSER of standard input\n"
      "Rule and conventions: docs/STEADY_STATE.md.\n"
      "Exit codes: 0 done; 1 input or usage error (the message names the line); 3 stdout not writable.");
  cmd->add_option("input", opt.input, "Series file, or - for standard input (the default)")->type_name("FILE|-");
  cmd->add_option("--batch,-m", opt.batch, "Batch size M >= 1 (default 5: MSER-5)")->type_name("M");
}

int mser_main(const MserOptions& opt, std::istream& in, std::ostream& out, std::ostream& err) {
  try {
    const std::size_t batch = parse_batch(opt.batch);
    std::vector<double> y;
    if (opt.input.empty() || opt.input == "-") {
      y = read_series(in, "<stdin>");
    } else {
      if (std::filesystem::is_directory(opt.input)) throw MserInputError(opt.input + " is a directory, not a series file");
      std::ifstream file(opt.input);
      if (!file) throw MserInputError("cannot open " + opt.input + ": " + std::strerror(errno));
      y = read_series(file, opt.input);
    }
    if (y.size() / batch < 2)
      throw MserInputError("series too short: " + std::to_string(y.size()) + " observation(s) give " +
                           std::to_string(y.size() / batch) + " batch(es) of " + std::to_string(batch) +
                           "; MSER needs at least 2 batches (" + std::to_string(2 * batch) + " observations)");
    const MserResult r = mser(y, batch);
    nlohmann::ordered_json j;
    j["truncation"] = r.truncation;
    j["steady"] = r.steady;
    j["batches"] = r.batches;
    j["statistic"] = r.statistic;
    j["n"] = y.size();
    out << j.dump() << '\n';
    return 0;
  } catch (const MserInputError& e) {
    err << "ringsim mser: " << e.what() << '\n';
    return 1;
  } catch (const std::invalid_argument& e) {  // from mser(); not expected after the checks above
    err << "ringsim mser: " << e.what() << '\n';
    return 1;
  }
}

}  // namespace ringsim
