#include "tether/core/key.h"

#include <cctype>

namespace tether {

std::string KeyToString(Key k) {
  const unsigned char letter = static_cast<unsigned char>(SymbolLetter(k));
  if (letter != 0 && std::isalpha(letter)) {
    return std::string(1, static_cast<char>(letter)) + std::to_string(SymbolIndex(k));
  }
  return std::to_string(k);
}

}  // namespace tether
