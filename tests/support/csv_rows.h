// A CSV file of the tools (fixes.csv, truth.csv) as the numbers of each row by its first
// column, for tests that compare two of them; the word "ok" reads as 1, other words as 0.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace ips::test {

inline std::map<std::string, std::vector<double>> csv_rows(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);  // the header
  std::map<std::string, std::vector<double>> out;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string cell, name;
    std::getline(ss, name, ',');
    while (std::getline(ss, cell, ',')) out[name].push_back(cell == "ok" ? 1.0 : std::atof(cell.c_str()));
  }
  return out;
}

}  // namespace ips::test
