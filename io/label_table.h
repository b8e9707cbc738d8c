#pragma once
// Names of the labels of a segmentation (atlas tables beside the image, FreeSurfer / ITK-SNAP
// colour tables), carried into exported meshes as region, group and set names.

#include <array>
#include <cstdint>
#include <map>
#include <string>

#include "pipeline/core/ids.h"

namespace frontmesh::io {

/// An sRGB colour, 0..255 per channel.
using Rgb = std::array<std::uint8_t, 3>;

/// Label id -> name (and colour where the table gives one). Ids without a name get
/// "region_<id>".
class LabelTable {
public:
    /// Sets the name of `label` (replacing an earlier one).
    void set(core::Label label, const std::string& name);
    bool has(core::Label label) const { return names_.count(label) != 0; }
    bool empty() const { return names_.empty(); }
    std::size_t size() const { return names_.size(); }
    const std::map<core::Label, std::string>& names() const { return names_; }

    /// The name as given in the table, or "region_<id>".
    std::string name(core::Label label) const;

    /// Sets the colour of `label` (FreeSurfer LUT, ITK-SNAP label description).
    void set_colour(core::Label label, const Rgb& rgb) { colours_[label] = rgb; }
    /// The table's colour of `label`, else default_colour(label).
    Rgb colour(core::Label label) const;

    /// A name usable as an identifier in every export format: letters, digits and '_' only,
    /// starting with a letter, at most 64 characters; unique within this table (a clash gets
    /// "_<id>" appended). "region_<id>" for labels without a name.
    std::string safe_name(core::Label label) const;

private:
    std::map<core::Label, std::string> names_;
    std::map<core::Label, Rgb> colours_;
    mutable std::map<core::Label, std::string> safe_;  // built on first use, deduplicated
    mutable bool safe_ready_ = false;
    void rebuild_safe_names() const;
};

/// A colour for `label` from a fixed palette of 12 distinct colours (label 0: grey), the
/// same for a label in every run: label l > 0 gets entry (l - 1) mod 12.
Rgb default_colour(core::Label label);

/// Reads a label table. Accepted line styles (one label per line; blank lines and lines
/// starting with '#' or '//' ignored; CRLF accepted; tabs, spaces or commas separate):
///   - "ID NAME [NUMBER ...]"        mricron atlas .txt (aal.nii.txt), CSV "ID,NAME"; NAME
///                                   is every word up to the first number ("1 Grey matter")
///   - "ID NAME R G B [A]"           FreeSurfer LUT (FreeSurferColorLUT.txt)
///   - "ID R G B A VIS MESH \"NAME\"" ITK-SNAP label description (name in double quotes)
/// Colours: the R G B of FreeSurfer and ITK-SNAP lines (three whole numbers 0..255 right
/// after the name, or right after the id with a quoted name); other labels keep
/// default_colour. A header line whose first field is not a number is skipped only when it
/// is the first non-comment line. Label 0 (background) may be present and is kept.
/// Throws InputError naming "file:line" for a bad line (id not an integer, no name,
/// duplicate id) and for a missing, unreadable or binary file (e.g. mricron's binary .lut
/// colour maps, which hold no names).
LabelTable read_label_table(const std::string& path);

/// The label table stored beside `image_path`, if any: for "dir/aal.nii.gz" the first of
/// "dir/aal.nii.txt", "dir/aal.txt", "dir/aal.nii.lut", "dir/aal.lut" that is a text file.
/// Returns an empty string when there is none.
std::string label_table_beside(const std::string& image_path);

/// Makes `name` an identifier: characters other than letters, digits and '_' become '_',
/// runs of '_' collapse, leading/trailing '_' are dropped, a leading digit gets "R_" in
/// front; empty results become "region". At most 64 characters.
std::string sanitized_name(const std::string& name);

}  // namespace frontmesh::io
