#pragma once
// One table of names per enum, so that ToString and FromString (and the CLI, the reports and
// the bindings that use them) agree by construction:
//
//   constexpr EnumName<InitMethod> kInitNames[] = {
//       {InitMethod::kFile, "file"}, {InitMethod::kSpanningTree, "spanning-tree"}, ...};
//   const char* ToString(InitMethod m) { return NameOf(kInitNames, m); }
//   bool FromString(const std::string& s, InitMethod* m) { return ValueOf(kInitNames, s, m); }
#include <cstddef>
#include <string>
#include <string_view>

namespace tether {

template <class E>
struct EnumName {
  E value;
  const char* name;
};

/// The name of `v` in `table`; `unknown` where it is not there.
template <class E, std::size_t N>
const char* NameOf(const EnumName<E> (&table)[N], E v, const char* unknown = "unknown") {
  for (const EnumName<E>& e : table) {
    if (e.value == v) return e.name;
  }
  return unknown;
}

/// The value named `s`; false (and *out untouched) where no entry has that name.
template <class E, std::size_t N>
bool ValueOf(const EnumName<E> (&table)[N], std::string_view s, E* out) {
  for (const EnumName<E>& e : table) {
    if (s == e.name) {
      *out = e.value;
      return true;
    }
  }
  return false;
}

/// "a, b or c": the names, for messages.
template <class E, std::size_t N>
std::string NameList(const EnumName<E> (&table)[N]) {
  std::string s;
  for (std::size_t i = 0; i < N; ++i) s += std::string(i == 0 ? "" : i + 1 == N ? " or " : ", ") + table[i].name;
  return s;
}

}  // namespace tether
