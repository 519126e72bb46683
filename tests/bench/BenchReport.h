// BenchReport.h: benchmarks write their figures into docs/benchmarks.md between markers
// <!-- bench:NAME --> and <!-- /bench:NAME -->, so each can be rerun alone.
#pragma once

#include <fstream>
#include <sstream>
#include <string>

namespace nimbus::bench {

inline void replaceSection(const std::string& path, const std::string& name, const std::string& body)
{
    std::string begin = "<!-- bench:" + name + " -->", end = "<!-- /bench:" + name + " -->";
    std::string text;
    {
        std::ifstream in(path);
        std::stringstream ss;
        ss << in.rdbuf();
        text = ss.str();
    }
    std::string block = begin + "\n" + body + end;
    size_t a = text.find(begin), b = text.find(end);
    if (a != std::string::npos && b != std::string::npos && b > a)
        text = text.substr(0, a) + block + text.substr(b + end.size());
    else
        text += (text.empty() || text.back() == '\n' ? "" : "\n") + std::string("\n") + block + "\n";
    std::string tmp = path + ".tmp";
    {
        std::ofstream out(tmp);
        out << text;
    }
    std::rename(tmp.c_str(), path.c_str());
}

}  // namespace nimbus::bench
