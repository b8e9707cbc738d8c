#pragma once
// One declaration per recipe key (STYLE §3). Each stage keeps a table of its keys beside its
// `validate` (e.g. volume/tetra_params.cpp): recipe key, the member it sets, default, range,
// unit and a one-line doc. The stage's validate() checks the ranges from that table, the
// recipe reader parses and range-checks with it, `frontmesh keys` prints it, and the tests
// compare it with the params struct's member defaults and with configs/reference.yaml.

#include <cmath>
#include <cstddef>
#include <limits>
#include <sstream>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

#include "pipeline/core/error.h"

namespace frontmesh::core {

/// The allowed values of a number: [lo, hi], either end open or unbounded (infinite).
struct ParamRange {
    double lo = -std::numeric_limits<double>::infinity();
    double hi = std::numeric_limits<double>::infinity();
    bool lo_open = false;  ///< true: lo itself is not allowed
    bool hi_open = false;

    /// False for NaN, and for infinity unless the range is unbounded on that side.
    bool contains(double v) const {
        if (std::isnan(v)) return false;
        return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
    }
    /// "[0, 100]", "(1, 2]", ">= 0"
    std::string text() const {
        std::ostringstream s;
        s.precision(10);
        if (std::isinf(hi)) {
            s << (lo_open ? "> " : ">= ") << lo;
        } else if (std::isinf(lo)) {
            s << (hi_open ? "< " : "<= ") << hi;
        } else {
            s << (lo_open ? '(' : '[') << lo << ", " << hi << (hi_open ? ')' : ']');
        }
        return s.str();
    }
    /// The one line for a value outside: "must be in (1, 2], got 1" (`got` is the value as
    /// the user wrote it); "must be greater than 1, got 1" when it sits on an open lower end.
    std::string violation(double v, const std::string& got) const {
        std::ostringstream s;
        s.precision(10);
        if (lo_open && v == lo && !std::isinf(hi))
            s << "must be greater than " << lo << ", got " << got;
        else
            s << "must be " << (std::isinf(lo) || std::isinf(hi) ? "" : "in ") << text() << ", got "
              << got;
        return s.str();
    }
};

/// [lo, hi]
inline ParamRange closed(double lo, double hi) { return {lo, hi, false, false}; }
/// (lo, hi]
inline ParamRange above_up_to(double lo, double hi) { return {lo, hi, true, false}; }
/// [lo, hi)
inline ParamRange from_below(double lo, double hi) { return {lo, hi, false, true}; }

/// One recipe key of a stage whose parameters are a `Params` struct.
template <typename Params>
struct ParamSpec {
    /// The member the key sets; std::monostate for a key the reader and validate() handle
    /// by hand (a choice, a map), still declared here with its default, range and doc.
    using Field = std::variant<std::monostate, bool Params::*, int Params::*, std::size_t Params::*,
                               double Params::*>;

    std::string_view key;           ///< "tetra.stretching"
    Field field;                    ///< the member of Params
    std::string_view default_yaml;  ///< as YAML text; equals the member's initialiser
    ParamRange range;               ///< of the value (of each value, for a map); unused for bool
    std::string_view unit;          ///< "mm", "deg", "voxels", ...; empty: dimensionless or a count
    std::string_view doc;           ///< one line
    std::string_view choices = {};  ///< a choice's values in the enum's order: "a, b, c"
};

/// The values of a choice, split at ", ".
inline std::vector<std::string> choice_list(std::string_view choices) {
    std::vector<std::string> list;
    while (!choices.empty()) {
        const std::size_t comma = choices.find(", ");
        list.emplace_back(choices.substr(0, comma));
        choices = comma == std::string_view::npos ? std::string_view() : choices.substr(comma + 2);
    }
    return list;
}

template <typename Params>
using ParamTable = std::vector<ParamSpec<Params>>;

/// The number a typed field of `params` holds (bool as 0 or 1); NaN for a hand-read key.
template <typename Params>
double field_value(const Params& params, const typename ParamSpec<Params>::Field& field) {
    return std::visit(
        [&](auto member) -> double {
            if constexpr (std::is_same_v<decltype(member), std::monostate>)
                return std::numeric_limits<double>::quiet_NaN();
            else
                return static_cast<double>(params.*member);
        },
        field);
}

/// The value of a number as a user would write it: "1.15", "200", "1e-06".
inline std::string value_text(double v) {
    std::ostringstream s;
    s.precision(10);
    s << v;
    return s.str();
}

/// Throws InputError "KEY: must be in RANGE, got VALUE" for the first typed member of
/// `params` outside its declared range (bools have none).
template <typename Params>
void check_ranges(const Params& params, const ParamTable<Params>& table) {
    for (const auto& spec : table) {
        if (std::holds_alternative<std::monostate>(spec.field) ||
            std::holds_alternative<bool Params::*>(spec.field))
            continue;
        const double v = field_value(params, spec.field);
        if (!spec.range.contains(v))
            FM_THROW(InputError,
                     std::string(spec.key) + ": " + spec.range.violation(v, value_text(v)));
    }
}

/// The spec of `key` in `table`; nullptr when there is none.
template <typename Params>
const ParamSpec<Params>* find_spec(const ParamTable<Params>& table, std::string_view key) {
    for (const auto& spec : table)
        if (spec.key == key) return &spec;
    return nullptr;
}

}  // namespace frontmesh::core
