#include "ensemble/cli_checks.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstring>
#include <filesystem>

#include "ensemble/config.hpp"

namespace ringsim {

namespace {

const char* file_kind(mode_t m) {
  if (S_ISDIR(m)) return "a directory";
  if (S_ISCHR(m)) return "a character device";
  if (S_ISBLK(m)) return "a block device";
  if (S_ISFIFO(m)) return "a FIFO (named pipe)";
  if (S_ISSOCK(m)) return "a socket";
  return "not a regular file";
}

// The first leading part of `path`'s directory (e.g. "X" of "X/sub/out.h5")
// that exists but is not a directory, with its stat; empty when there is none.
std::string blocking_ancestor(const std::string& path, struct stat* st) {
  std::filesystem::path prefix;
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  for (const std::filesystem::path& part : dir) {
    prefix /= part;
    if (::stat(prefix.c_str(), st) != 0) return "";  // missing (or unreadable): no blocker found
    if (!S_ISDIR(st->st_mode)) return prefix.string();
  }
  return "";
}

[[noreturn]] void throw_blocked(const std::string& what, const std::string& path, const std::string& blocker,
                                const struct stat& st) {
  throw ConfigError(what + " " + path + ": cannot create the file: '" + blocker + "' is " +
                    (S_ISREG(st.st_mode) ? std::string("a regular file") : file_kind(st.st_mode)) +
                    ", not a directory");
}

}  // namespace

void check_output_path(const std::string& path, const std::string& what) {
  if (path.empty()) throw ConfigError(what + ": the path is empty");
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    if (!S_ISREG(st.st_mode))
      throw ConfigError(what + " " + path + " is " + file_kind(st.st_mode) +
                        "; ringsim writes only regular files (give a file path)");
  } else if (errno == ENOTDIR) {  // a leading part of the path is a file, e.g. -o X/out.h5 with X a file
    struct stat bst {};
    const std::string blocker = blocking_ancestor(path, &bst);
    if (!blocker.empty()) throw_blocked(what, path, blocker, bst);
    throw ConfigError(what + " " + path + ": " + std::strerror(ENOTDIR));
  } else if (errno != ENOENT) {
    throw ConfigError(what + " " + path + ": " + std::strerror(errno));
  }
  std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (parent.empty()) parent = ".";
  struct stat pst {};
  if (::stat(parent.c_str(), &pst) != 0) {
    struct stat bst {};
    const std::string blocker = blocking_ancestor(path, &bst);
    if (!blocker.empty()) throw_blocked(what, path, blocker, bst);
    throw ConfigError(what + " " + path + ": directory " + parent.string() + " does not exist");
  }
  if (!S_ISDIR(pst.st_mode)) throw_blocked(what, path, parent.string(), pst);
  if (::access(parent.c_str(), W_OK | X_OK) != 0)
    throw ConfigError(what + " " + path + ": directory " + parent.string() + " is not writable (" +
                      std::strerror(errno) + ")");
}

CLI::Validator unsigned64() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        const std::string range = "an integer in [0, 18446744073709551615]";
        bool digits = !s.empty();
        for (char c : s) digits = digits && c >= '0' && c <= '9';
        if (!digits) return "value " + s + " is not " + range;
        // Compare as decimal strings: no conversion can wrap.
        std::size_t first = s.find_first_not_of('0');
        const std::string t = first == std::string::npos ? "0" : s.substr(first);
        const std::string max = "18446744073709551615";
        if (t.size() > max.size() || (t.size() == max.size() && t > max))
          return "value " + s + " is out of range: must be " + range;
        return "";
      },
      "UINT64");
}

}  // namespace ringsim
