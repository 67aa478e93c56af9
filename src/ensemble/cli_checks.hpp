#pragma once
// Checks on command-line values made before any work starts, so a bad value
// fails in a second with a message naming the option, the value and what is
// allowed, instead of after a whole simulation (or never, as a FIFO would).

#include <string>

namespace CLI {
class Validator;
}

namespace ringsim {

// Throws ConfigError unless `path` can be written as a regular file: when it
// exists it must be a regular file (after symlinks; a device, FIFO, socket
// or directory is refused, so `-o /dev/null --force` never replaces
// /dev/null and a FIFO never blocks the open), and its parent directory must
// exist and be writable. `what` names the option in the message, e.g. "--output".
void check_output_path(const std::string& path, const std::string& what);

// A CLI11 check for an unsigned 64-bit option (--seed, --replicate): plain
// decimal digits in [0, 2^64 - 1]. CLI11 itself wraps "-1" and values past
// 2^64 - 1 to 18446744073709551615 without a word.
CLI::Validator unsigned64();

}  // namespace ringsim
