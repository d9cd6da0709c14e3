#pragma once
// Keys name variables. A Key is a plain 64-bit integer: file ids (g2o, TORO) are used as
// they are, and Symbol('x', 12) packs a readable letter into the top byte, printed "x12".
#include <cstdint>
#include <string>

namespace tether {

using Key = std::uint64_t;

/// A key with a letter: Symbol('l', 3) prints as "l3".
constexpr Key Symbol(char letter, std::uint64_t index) {
  return (static_cast<Key>(static_cast<unsigned char>(letter)) << 56) | (index & ((Key(1) << 56) - 1));
}
inline char SymbolLetter(Key k) { return static_cast<char>(k >> 56); }
inline std::uint64_t SymbolIndex(Key k) { return k & ((Key(1) << 56) - 1); }

/// "x12" for symbol keys, the plain number otherwise.
std::string KeyToString(Key k);

}  // namespace tether
