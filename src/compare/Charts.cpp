// Charts.cpp: drawCompareCharts (Charts.h).
#include "Charts.h"

#include "Report.h"

#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstring>
#include <vector>

extern char** environ;

namespace nimbus {

std::string drawCompareCharts(const ChartInputs& in, const std::string& script)
{
    std::vector<std::string> args = {kChartPython, script, in.dir, "--title", in.title,
                                      "--reference-noise", fmt("%.6g", in.referenceNoise)};
    if (!in.wkbModel.empty())
        args.insert(args.end(), {"--wkb", in.wkbModel});
    std::vector<char*> argv;
    for (std::string& a : args)
        argv.push_back(a.data());
    argv.push_back(nullptr);

    const std::string what = std::string(kChartPython) + " " + script;
    const std::string hint = " (the charts need Debian's python3-matplotlib: scripts/install-deps.sh)";
    pid_t pid = 0;
    if (const int err = posix_spawn(&pid, kChartPython, nullptr, nullptr, argv.data(), environ))
        return "cannot run " + what + ": " + std::strerror(err) + hint;
    int status = 0;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR)
            return "lost " + what + ": " + std::strerror(errno);
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0)
        return {};
    if (WIFSIGNALED(status))
        return what + " died of signal " + std::to_string(WTERMSIG(status));
    return what + " exited with status " + std::to_string(WEXITSTATUS(status)) + hint;
}

}  // namespace nimbus
