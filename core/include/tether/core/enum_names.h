#pragma once
// One table of names per enum, so that ToString, FromString, operator<< (and the CLI, the
// reports and the bindings that use them) agree by construction. An enum joins by declaring its
// table next to it and a function that finds the table (found by argument-dependent lookup):
//
//   enum class InitMethod { kFile, kSpanningTree, kChordal };
//   inline constexpr EnumName<InitMethod> kInitMethodNames[] = {
//       {InitMethod::kFile, "file"}, {InitMethod::kSpanningTree, "spanning-tree"}, ...};
//   constexpr const auto& EnumNames(InitMethod) { return kInitMethodNames; }
//
// Then ToString(m), FromString("chordal", &m), `std::cout << m`, EnumNameList<InitMethod>()
// ("file, spanning-tree or chordal") and EnumNameVector<InitMethod>() work for it, and the
// command line and Python take exactly those names. An enum in a nested namespace brings the
// templates in with `using ::tether::ToString;` (and FromString, operator<<).
#include <cstddef>
#include <ostream>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

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

/// An enum that has a name table (see above).
template <class E>
using IfNamedEnum = std::enable_if_t<std::is_enum_v<E>, decltype(EnumNames(E{}))>;

/// The name of `v`; "unknown" for a value outside the table.
template <class E, class = IfNamedEnum<E>>
const char* ToString(E v) {
  return NameOf(EnumNames(v), v);
}

/// The value named `s`; false (and *out untouched) where no value has that name.
template <class E, class = IfNamedEnum<E>>
bool FromString(std::string_view s, E* out) {
  return ValueOf(EnumNames(E{}), s, out);
}

/// "a, b or c".
template <class E, class = IfNamedEnum<E>>
std::string EnumNameList() {
  return NameList(EnumNames(E{}));
}

/// Every name, in the table's order.
template <class E, class = IfNamedEnum<E>>
std::vector<std::string> EnumNameVector() {
  std::vector<std::string> names;
  for (const auto& e : EnumNames(E{})) names.emplace_back(e.name);
  return names;
}

template <class E, class = IfNamedEnum<E>>
std::ostream& operator<<(std::ostream& os, E v) {
  return os << ToString(v);
}

}  // namespace tether
