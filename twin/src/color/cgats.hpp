// Reader for the CGATS.17 text files of colord-data (CIE tables): keywords, the data
// format (field names) and the data sets. Only what the spectral tables use is supported:
// one table per file, numeric data. Internal to the color family.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace gonio::twin::cgats {

struct Table {
  std::string path;
  std::string type;                                   // first token of line 1: "CMF", "SPECT"
  std::map<std::string, std::pair<std::string, int>> keywords;  // value, line number
  std::vector<std::string> fields;                    // BEGIN_DATA_FORMAT … END_DATA_FORMAT
  std::vector<std::vector<double>> sets;              // one row per set, fields.size() values
  int data_line = 0;                                  // line of BEGIN_DATA

  // A keyword's numeric value; Error(parse_error) naming file and line when absent or bad.
  double number(const std::string& key) const;
  // Wavelengths of the fields from SPECTRAL_START_NM, SPECTRAL_END_NM, SPECTRAL_BANDS
  // (evenly spaced, both ends included), checked against the field and data counts.
  std::vector<double> wavelengths() const;
};

// Reads `path`. `package` names the Debian package in the not_found message.
// Errors: not_found (missing file), io_error (unreadable), parse_error ("file:line: why").
Table read(const std::string& path, const std::string& package = "colord-data");

}  // namespace gonio::twin::cgats
