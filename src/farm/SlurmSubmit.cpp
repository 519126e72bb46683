#include "SlurmSubmit.h"

#include "../core/Error.h"

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <fcntl.h>
#include <poll.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace nimbus {

namespace {

using nlohmann::json;
namespace fs = std::filesystem;

const char* const kWhere = "farm submit: ";

// A word for bash, single-quoted: what is inside is taken literally ("'" becomes '\'').
std::string shellQuote(const std::string& word)
{
    std::string quoted = "'";
    for (char c : word) {
        if (c == '\'')
            quoted += "'\\''";
        else
            quoted += c;
    }
    return quoted + "'";
}

// The first executable `name` on PATH, or "".
std::string findOnPath(const std::string& name)
{
    const char* path = std::getenv("PATH");
    std::stringstream dirs(path ? path : "");
    std::string dir;
    while (std::getline(dirs, dir, ':')) {
        const fs::path candidate = fs::path(dir.empty() ? "." : dir) / name;
        std::error_code ec;
        if (fs::is_regular_file(candidate, ec) && ::access(candidate.c_str(), X_OK) == 0)
            return candidate.string();
    }
    return "";
}

struct CommandResult {
    int status = -1;  // exit status; 128 + signal when killed
    std::string out, err;
};

// Runs argv (argv[0] a path) without a shell and collects its stdout and stderr (both read as they
// come, so neither pipe can fill and stall the child).
CommandResult runCommand(const std::vector<std::string>& argv)
{
    int outPipe[2], errPipe[2];
    if (::pipe(outPipe) != 0)
        throw InputError(std::string(kWhere) + "cannot run " + argv[0] + ": " + std::strerror(errno));
    if (::pipe(errPipe) != 0) {
        ::close(outPipe[0]);
        ::close(outPipe[1]);
        throw InputError(std::string(kWhere) + "cannot run " + argv[0] + ": " + std::strerror(errno));
    }
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, outPipe[1], 1);
    posix_spawn_file_actions_adddup2(&actions, errPipe[1], 2);
    posix_spawn_file_actions_addclose(&actions, outPipe[0]);
    posix_spawn_file_actions_addclose(&actions, errPipe[0]);
    std::vector<char*> args;
    for (const std::string& a : argv)
        args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    pid_t pid = 0;
    const int spawned = posix_spawn(&pid, argv[0].c_str(), &actions, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(outPipe[1]);
    ::close(errPipe[1]);
    CommandResult result;
    if (spawned != 0) {
        ::close(outPipe[0]);
        ::close(errPipe[0]);
        throw InputError(std::string(kWhere) + "cannot run " + argv[0] + ": " + std::strerror(spawned));
    }
    pollfd fds[2] = {{outPipe[0], POLLIN, 0}, {errPipe[0], POLLIN, 0}};
    std::string* sinks[2] = {&result.out, &result.err};
    int open = 2;
    while (open > 0) {
        if (::poll(fds, 2, -1) < 0) {
            if (errno == EINTR)
                continue;
            break;
        }
        for (int i = 0; i < 2; ++i) {
            if (fds[i].fd < 0 || fds[i].revents == 0)
                continue;
            char buffer[4096];
            const ssize_t n = ::read(fds[i].fd, buffer, sizeof buffer);
            if (n > 0) {
                sinks[i]->append(buffer, size_t(n));
            } else if (n == 0 || errno != EINTR) {
                ::close(fds[i].fd);
                fds[i].fd = -1;
                --open;
            }
        }
    }
    for (pollfd& f : fds)
        if (f.fd >= 0)
            ::close(f.fd);
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    result.status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return result;
}

// The first non-empty line of `text`, trimmed: sbatch's error for the one error line.
std::string firstLine(const std::string& text)
{
    std::stringstream lines(text);
    std::string line;
    while (std::getline(lines, line)) {
        const size_t a = line.find_first_not_of(" \t\r");
        if (a != std::string::npos)
            return line.substr(a, line.find_last_not_of(" \t\r") + 1 - a);
    }
    return "(no message)";
}

// Written whole to a temporary file beside `path`, then renamed over it.
void writeFile(const fs::path& path, const std::string& text, bool executable)
{
    const fs::path temp = path.parent_path() / ("." + path.filename().string() + ".nimbus-tmp");
    {
        std::ofstream file(temp, std::ios::binary | std::ios::trunc);
        file << text;
        file.close();
        if (!file)
            throw InputError(std::string(kWhere) + "cannot write '" + temp.string() + "': " + std::strerror(errno));
    }
    if (executable)
        ::chmod(temp.c_str(), 0755);
    std::error_code ec;
    fs::rename(temp, path, ec);
    if (ec)
        throw InputError(std::string(kWhere) + "cannot write '" + path.string() + "': " + ec.message());
}

// One array's script: the plan's tasks of a group, chosen by SLURM_ARRAY_TASK_ID, each run up to
// 1 + retries times (docs/farm.md, "Slurm").
std::string arrayScript(const json& plan, const std::vector<const json*>& tasks, const std::string& group,
                        const std::string& jobName, const fs::path& logDir, const std::vector<std::string>& sbatchArgs)
{
    std::ostringstream s;
    const std::string last = std::to_string(tasks.size() - 1);
    s << "#!/bin/bash\n"
      << "# Written by `nimbus farm submit --engine slurm` (docs/farm.md, \"Slurm\"): the " << group
      << " tasks of " << (plan["scene"].is_string() ? plan["scene"].get<std::string>() : std::string("the default scene"))
      << ",\n# one per array index (plan.json beside this script lists them). Each runs its command up to\n"
      << "# 1 + retries times: exit 2 (bad input) is final; a kill or a failure is retried, and a path-tracer\n"
      << "# task resumes from its checkpoint. --requeue lets Slurm requeue a preempted task.\n"
      << "#SBATCH --job-name=" << jobName << "-" << group << "\n"
      << "#SBATCH --array=0-" << last << "\n"
      << "#SBATCH --output=" << (logDir / (group + "_%A_%a.out")).string() << "\n"
      << "#SBATCH --error=" << (logDir / (group + "_%A_%a.err")).string() << "\n"
      << "#SBATCH --open-mode=append\n"
      << "#SBATCH --requeue\n"
      << "#SBATCH --chdir=" << plan["cwd"].get<std::string>() << "\n";
    for (const std::string& a : sbatchArgs)
        s << "#SBATCH " << a << "\n";
    s << "set -u\n"
      << "case \"${SLURM_ARRAY_TASK_ID:-}\" in\n";
    for (size_t i = 0; i < tasks.size(); ++i) {
        const json& t = *tasks[i];
        s << i << ") id=" << shellQuote(t["id"].get<std::string>()) << " retries=" << t["retries"].get<int>()
          << "\n   cmd=(";
        bool first = true;
        for (const json& word : t["command"]) {
            s << (first ? "" : " ") << shellQuote(word.get<std::string>());
            first = false;
        }
        s << ") ;;\n";
    }
    s << "*) echo \"nimbus-farm: no task '${SLURM_ARRAY_TASK_ID:-}' in this array (0-" << last
      << "): run it with sbatch\" >&2\n   exit 2 ;;\n"
      << "esac\n"
      << "# Slurm signals the whole job when it preempts, cancels or times it out: no retry then.\n"
      << "terminated=0\n"
      << "trap 'terminated=1' TERM INT\n"
      << "echo \"nimbus-farm: $id: array task ${SLURM_ARRAY_JOB_ID:-?}_${SLURM_ARRAY_TASK_ID} on $(hostname),"
         " Slurm restart ${SLURM_RESTART_COUNT:-0}\" >&2\n"
      << "attempt=1\n"
      << "while :; do\n"
      << "  start=$SECONDS\n"
      << "  \"${cmd[@]}\"\n"
      << "  rc=$?\n"
      << "  if [ \"$rc\" -eq 0 ]; then\n"
      << "    echo \"nimbus-farm: $id: done on attempt $attempt ($((SECONDS - start)) s)\" >&2\n"
      << "    exit 0\n"
      << "  fi\n"
      << "  if [ \"$rc\" -gt 128 ]; then how=\"killed by signal $((rc - 128))\"; else how=\"exit $rc\"; fi\n"
      << "  if [ \"$terminated\" -eq 1 ]; then\n"
      << "    echo \"nimbus-farm: $id: attempt $attempt $how: the job was signalled (preempted, cancelled or out of"
         " time); Slurm requeues it if it was preempted\" >&2\n"
      << "    exit \"$rc\"\n"
      << "  fi\n"
      << "  if [ \"$rc\" -eq 2 ]; then\n"
      << "    echo \"nimbus-farm: $id: attempt $attempt exit 2 (bad input): not retried\" >&2\n"
      << "    exit 2\n"
      << "  fi\n"
      << "  if [ \"$attempt\" -gt \"$retries\" ]; then\n"
      << "    echo \"nimbus-farm: $id: attempt $attempt of $((retries + 1)) $how: no retries left\" >&2\n"
      << "    exit \"$rc\"\n"
      << "  fi\n"
      << "  echo \"nimbus-farm: $id: attempt $attempt of $((retries + 1)) $how: retrying\" >&2\n"
      << "  attempt=$((attempt + 1))\n"
      << "done\n";
    return s.str();
}

// The submission by hand, as nimbus farm submit does it.
std::string submitScript(bool merges)
{
    std::ostringstream s;
    s << "#!/bin/bash\n"
      << "# Submits this folder's job as `nimbus farm submit --engine slurm` does (docs/farm.md, \"Slurm\").\n"
      << "set -euo pipefail\n"
      << "cd \"$(dirname \"$0\")\"\n"
      << "render=$(sbatch --parsable render.sbatch)\n"
      << "render=${render%%;*}\n"
      << "echo \"render $render\"\n";
    if (merges)
        s << "merge=$(sbatch --parsable --dependency=afterok:$render --kill-on-invalid-dep=yes merge.sbatch)\n"
          << "merge=${merge%%;*}\n"
          << "echo \"merge $merge\"\n";
    return s.str();
}

// The job folder when none is given: ./nimbus-farm/<scene stem>.<UTC time>[.<n>].
fs::path defaultJobDir(const json& plan)
{
    const std::string stem =
        plan["scene"].is_string() ? fs::path(plan["scene"].get<std::string>()).stem().string() : "default";
    const std::time_t now = std::time(nullptr);
    std::tm utc{};
    gmtime_r(&now, &utc);
    char stamp[32];
    std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &utc);
    const fs::path base = fs::path(plan["cwd"].get<std::string>()) / "nimbus-farm" / (stem + "." + stamp);
    fs::path dir = base;
    std::error_code ec;
    for (int n = 2; fs::exists(dir, ec); ++n)
        dir = base.string() + "." + std::to_string(n);
    return dir;
}

// sbatch --parsable prints "<job id>[;<cluster>]".
std::string submitArray(const std::string& sbatch, const std::vector<std::string>& args, const std::string& what)
{
    std::vector<std::string> argv = {sbatch, "--parsable"};
    argv.insert(argv.end(), args.begin(), args.end());
    const CommandResult r = runCommand(argv);
    if (r.status != 0)
        throw InputError(std::string(kWhere) + "sbatch refused the " + what + " array (exit " +
                         std::to_string(r.status) + "): " + firstLine(r.err + "\n" + r.out));
    std::string id = firstLine(r.out);
    id = id.substr(0, id.find(';'));
    if (id.empty() || id.find_first_not_of("0123456789") != std::string::npos)
        throw InputError(std::string(kWhere) + "sbatch printed no job id for the " + what + " array: '" +
                         firstLine(r.out) + "'");
    return id;
}

}  // namespace

SlurmSubmission submitSlurm(const json& plan, const SlurmOptions& options)
{
    std::map<std::string, const json*> byId;
    for (const json& t : plan["tasks"])
        byId[t["id"].get<std::string>()] = &t;
    std::vector<const json*> renders, merges;
    for (const json& g : plan["groups"]) {
        std::vector<const json*>& list = g["name"] == "merge" ? merges : renders;
        for (const json& id : g["tasks"])
            list.push_back(byId.at(id.get<std::string>()));
    }

    // Before anything is written: a submission needs sbatch.
    std::string sbatch;
    if (!options.dryRun) {
        sbatch = findOnPath("sbatch");
        if (sbatch.empty())
            throw InputError(std::string(kWhere) +
                             "--engine slurm: sbatch is not on PATH (run on a Slurm submit host, or --dry-run to write "
                             "the job's scripts only)");
    }

    std::error_code ec;
    const fs::path dir =
        options.jobDir.empty() ? defaultJobDir(plan) : fs::absolute(options.jobDir, ec).lexically_normal();
    if (fs::exists(dir, ec) && !(fs::is_directory(dir, ec) && fs::is_empty(dir, ec)))
        throw InputError(std::string(kWhere) + "--job-dir '" + dir.string() +
                         "' exists and is not an empty folder (the scripts and logs of another job?)");
    const fs::path logDir = dir / "logs";
    fs::create_directories(logDir, ec);
    if (ec)
        throw InputError(std::string(kWhere) + "cannot create the job folder '" + logDir.string() + "': " + ec.message());

    SlurmSubmission s;
    s.jobDir = dir.string();
    s.renderTasks = renders.size();
    s.mergeTasks = merges.size();
    writeFile(dir / "plan.json", plan.dump(2) + "\n", false);
    s.renderScript = (dir / "render.sbatch").string();
    writeFile(s.renderScript, arrayScript(plan, renders, "render", options.jobName, logDir, options.sbatchArgs), true);
    if (!merges.empty()) {
        s.mergeScript = (dir / "merge.sbatch").string();
        writeFile(s.mergeScript, arrayScript(plan, merges, "merge", options.jobName, logDir, options.sbatchArgs), true);
    }
    writeFile(dir / "submit.sh", submitScript(!merges.empty()), true);
    if (options.dryRun)
        return s;

    s.renderJobId = submitArray(sbatch, {s.renderScript}, "render");
    if (!merges.empty()) {
        try {
            s.mergeJobId = submitArray(
                sbatch, {"--dependency=afterok:" + s.renderJobId, "--kill-on-invalid-dep=yes", s.mergeScript}, "merge");
        } catch (const InputError& e) {
            // No half of a job left queued: the renders would run for merges that never come.
            const std::string scancel = findOnPath("scancel");
            const bool cancelled = !scancel.empty() && runCommand({scancel, s.renderJobId}).status == 0;
            throw InputError(std::string(e.what()) + (cancelled ? "; the render array " + s.renderJobId + " was cancelled"
                                                                : "; cancel the render array " + s.renderJobId +
                                                                      " (scancel " + s.renderJobId + ")"));
        }
    }
    json jobs = {{"render", s.renderJobId}, {"render_tasks", s.renderTasks}};
    if (!merges.empty())
        jobs.update({{"merge", s.mergeJobId}, {"merge_tasks", s.mergeTasks}});
    writeFile(dir / "jobs.json", jobs.dump(2) + "\n", false);
    return s;
}

}  // namespace nimbus
