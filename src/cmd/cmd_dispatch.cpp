// `lensim dispatch SCENE --engine slurm|kubernetes --jobs N`: writes the job files that render a
// scene as N parts on a cluster scheduler and merge them (docs/cluster.md). lensim schedules
// nothing itself: Slurm's array jobs and Kubernetes' Indexed Jobs run the parts.
#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "lensim/render/parts.h"
#include "lensim/render/renderer.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"
#include "lensim/util/file.h"
#include "lensim/util/log.h"

namespace lensim::cmd {

namespace {

namespace fs = std::filesystem;

/// A word for the POSIX shell: single-quoted unless it is plainly safe.
std::string shq(const std::string& s) {
  const bool plain = !s.empty() && std::all_of(s.begin(), s.end(), [](unsigned char c) {
    return std::isalnum(c) || std::string_view("@%+=:,./_-").find(char(c)) != std::string::npos;
  });
  if (plain) return s;
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

/// A Kubernetes object name (RFC 1123 label) from a file stem.
std::string dnsLabel(const std::string& s) {
  std::string out;
  for (unsigned char c : s) out += std::isalnum(c) ? char(std::tolower(c)) : '-';
  while (!out.empty() && out.front() == '-') out.erase(out.begin());
  if (out.size() > 40) out.resize(40);
  while (!out.empty() && out.back() == '-') out.pop_back();
  return out.empty() ? "scene" : out;
}

struct Options {
  std::string scene, engine, split = "tiles", outdir = "lensim-jobs", output, workdir;
  std::string lensim = "lensim", checkpoint_every = "60s", render_args;
  int jobs = 0, threads = 0, spp = 0, seed = 0;
  bool has_seed = false;
  // Slurm
  std::string partition, time_limit;
  int cpus_per_task = 0;
  // Kubernetes
  std::string image = "lensim:latest", pvc = "lensim-data";
  int parallelism = 0;
  std::string cpu_request;
};

/// The shell commands of part $I (I from the environment variable `index_var`).
std::string renderScript(const Options& o, const std::vector<std::string>& part_args,
                         const std::string& index_var, const std::string& threads) {
  std::string s;
  s += "set -eu\n";
  s += fmt::format("cd {}\n", shq(o.workdir));
  s += fmt::format("I=\"${}\"\n", index_var);
  s += "case \"$I\" in\n";
  for (size_t i = 0; i < part_args.size(); ++i)
    s += fmt::format("  {}) PART=\"{}\" ;;\n", i, part_args[i]);
  s += "  *) echo \"lensim: no part $I\" >&2; exit 1 ;;\nesac\n";
  s += fmt::format("mkdir -p {}/parts\n", shq(o.outdir));
  s += fmt::format("OUT={}/parts/part-$I.exr\n", shq(o.outdir));
  s += fmt::format("CK={}/parts/part-$I.ckpt.exr\n", shq(o.outdir));
  s += "# A part that was killed (preempted) goes on from its checkpoint.\n";
  s += "if [ -f \"$CK\" ]; then set -- --resume \"$CK\"; else set --; fi\n";
  std::string extra;
  if (o.spp > 0) extra += fmt::format(" --spp {}", o.spp);
  if (o.has_seed) extra += fmt::format(" --seed {}", o.seed);
  if (!o.render_args.empty()) extra += " " + o.render_args;
  s += fmt::format(
      "{} --quiet render {} $PART{} --threads {} --outfile \"$OUT\" --checkpoint \"$CK\" "
      "--checkpoint-every {} \"$@\"\n",
      shq(o.lensim), shq(o.scene), extra, threads, shq(o.checkpoint_every));
  s += "rm -f \"$CK\"\n";
  return s;
}

/// The shell commands that merge the N parts (after waiting for them when `wait`).
std::string mergeScript(const Options& o, bool wait) {
  std::string s;
  s += "set -eu\n";
  s += fmt::format("cd {}\n", shq(o.workdir));
  s += "set --\n";
  s += fmt::format(
      "i=0; while [ $i -lt {} ]; do set -- \"$@\" {}/parts/part-$i.exr; "
      "i=$((i+1)); done\n",
      o.jobs, shq(o.outdir));
  if (wait) {
    s += "# Parts are written atomically: a part file that exists is complete.\n";
    s += "for f in \"$@\"; do while [ ! -f \"$f\" ]; do sleep 5; done; done\n";
  }
  s += fmt::format("{} merge {} \"$@\"\n", shq(o.lensim), shq(o.output));
  return s;
}

void writeExecutable(const std::string& path, const std::string& text) {
  writeFileAtomically(path, text);
  fs::permissions(path, fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec,
                  fs::perm_options::add);
}

std::string yamlString(const std::string& s) {
  return nlohmann::json(s).dump();
}

/// The render arguments of each part (--tile I/N or --spp-range A:B). Loads the scene (from
/// the workdir when it is reachable) to check it and to plan the split before anything is
/// submitted.
std::vector<std::string> partArguments(const Options& o) {
  std::string local_scene = o.scene;
  if (fs::path(o.scene).is_relative() && fs::exists(fs::path(o.workdir) / o.scene))
    local_scene = (fs::path(o.workdir) / o.scene).string();
  const scene::Scene s = scene::loadScene(local_scene);
  render::RenderOptions ro;
  if (o.spp > 0) ro.spp = o.spp;
  if (o.has_seed) ro.seed = o.seed;
  const render::RenderPlan plan = render::planRender(s, ro);
  std::vector<std::string> part_args;
  for (int i = 0; i < o.jobs; ++i) {
    if (o.split == "tiles") {
      render::tileBounds(plan.full_bounds, i, o.jobs);  // throws if they do not fit
      part_args.push_back(fmt::format("--tile {}/{}", i, o.jobs));
    } else {
      if (o.jobs > plan.spp)
        throw Error(fmt::format("--jobs {}: more sample slices than the {} samples per pixel",
                                o.jobs, plan.spp));
      const int a = int((long long)i * plan.spp / o.jobs);
      const int b = int((long long)(i + 1) * plan.spp / o.jobs);
      part_args.push_back(fmt::format("--spp-range {}:{}", a, b));
    }
  }
  return part_args;
}

/// Writes the Slurm array job of the parts, the merge job and the script that submits both;
/// returns their paths.
std::vector<std::string> writeSlurmJobs(const Options& o,
                                        const std::vector<std::string>& part_args,
                                        const std::string& name) {
  const std::string threads =
      o.threads > 0 ? std::to_string(o.threads) : "\"${SLURM_CPUS_PER_TASK:-0}\"";
  std::string r = "#!/bin/bash\n";
  r += fmt::format("# lensim dispatch: render {} as {} parts ({}); submit with submit.sh.\n",
                   o.scene, o.jobs, o.split);
  r += fmt::format("#SBATCH --job-name=lensim-{}\n", name);
  r += fmt::format("#SBATCH --array=0-{}\n", o.jobs - 1);
  r +=
      fmt::format("#SBATCH --output={}/logs/part-%a.log\n", fs::absolute(o.outdir).string());
  r += "#SBATCH --open-mode=append\n#SBATCH --requeue\n";
  if (o.cpus_per_task > 0)
    r += fmt::format("#SBATCH --cpus-per-task={}\n", o.cpus_per_task);
  if (!o.partition.empty()) r += fmt::format("#SBATCH --partition={}\n", o.partition);
  if (!o.time_limit.empty()) r += fmt::format("#SBATCH --time={}\n", o.time_limit);
  r += renderScript(o, part_args, "SLURM_ARRAY_TASK_ID", threads);
  std::string m = "#!/bin/bash\n";
  m += "# lensim dispatch: merges the parts once the array job has succeeded.\n";
  m += fmt::format("#SBATCH --job-name=lensim-{}-merge\n", name);
  m += fmt::format("#SBATCH --output={}/logs/merge.log\n", fs::absolute(o.outdir).string());
  if (!o.partition.empty()) m += fmt::format("#SBATCH --partition={}\n", o.partition);
  m += mergeScript(o, false);
  std::string sub = "#!/bin/bash\n";
  sub += "# Submits the render array job and the merge that waits for it to succeed.\n";
  sub += "set -euo pipefail\ncd \"$(dirname \"$0\")\"\n";
  sub += "array=$(sbatch --parsable render.sbatch)\narray=${array%%;*}\n";
  sub += "merge=$(sbatch --parsable --dependency=afterok:\"$array\" merge.sbatch)\n";
  sub += "merge=${merge%%;*}\n";
  sub += "echo \"lensim: submitted render array job $array and merge job $merge\"\n";
  sub += "echo \"$array $merge\" > jobids\n";
  const fs::path dir(o.outdir);
  writeExecutable((dir / "render.sbatch").string(), r);
  writeExecutable((dir / "merge.sbatch").string(), m);
  writeExecutable((dir / "submit.sh").string(), sub);
  return {(dir / "render.sbatch").string(), (dir / "merge.sbatch").string(),
          (dir / "submit.sh").string()};
}

/// Writes job.yaml: an Indexed Job of the parts and a Job that merges them once every part
/// file is on the volume; returns its path.
std::vector<std::string> writeKubernetesJobs(const Options& o,
                                             const std::vector<std::string>& part_args,
                                             const std::string& name) {
  const std::string threads = o.threads > 0 ? std::to_string(o.threads) : "0";
  const nlohmann::json render_cmd = {
      "/bin/sh", "-c", renderScript(o, part_args, "JOB_COMPLETION_INDEX", threads)};
  const nlohmann::json merge_cmd = {"/bin/sh", "-c", mergeScript(o, true)};
  auto container = [&](const std::string& cname, const nlohmann::json& cmd) {
    std::string c;
    c += fmt::format("        - name: {}\n", cname);
    c += fmt::format("          image: {}\n", yamlString(o.image));
    c += fmt::format("          command: {}\n", cmd.dump());
    if (!o.cpu_request.empty())
      c += fmt::format(
          "          resources:\n            requests:\n              cpu: "
          "{}\n",
          yamlString(o.cpu_request));
    c += fmt::format(
        "          volumeMounts:\n            - name: data\n              "
        "mountPath: {}\n",
        yamlString(o.workdir));
    return c;
  };
  const std::string volumes = fmt::format(
      "      volumes:\n        - name: data\n          persistentVolumeClaim:\n"
      "            claimName: {}\n",
      yamlString(o.pvc));
  std::string y;
  y += fmt::format("# lensim dispatch: render {} as {} parts ({}) and merge them.\n",
                   o.scene, o.jobs, o.split);
  y +=
      "# kubectl apply -f job.yaml; the merge Job waits for every part file on the volume.\n";
  y += "apiVersion: batch/v1\nkind: Job\nmetadata:\n";
  y += fmt::format("  name: lensim-{}\n", name);
  y += "  labels:\n    app.kubernetes.io/name: lensim\n";
  y += "spec:\n  completionMode: Indexed\n";
  y += fmt::format("  completions: {}\n  parallelism: {}\n", o.jobs,
                   o.parallelism > 0 ? o.parallelism : o.jobs);
  y += fmt::format("  backoffLimit: {}\n", 3 * o.jobs);
  y += "  template:\n    metadata:\n      labels:\n        app.kubernetes.io/name: lensim\n";
  y += "    spec:\n      restartPolicy: OnFailure\n      containers:\n";
  y += container("render", render_cmd);
  y += volumes;
  y += "---\napiVersion: batch/v1\nkind: Job\nmetadata:\n";
  y += fmt::format("  name: lensim-{}-merge\n", name);
  y += "  labels:\n    app.kubernetes.io/name: lensim\n";
  y += "spec:\n  backoffLimit: 3\n  template:\n";
  y += "    metadata:\n      labels:\n        app.kubernetes.io/name: lensim\n";
  y += "    spec:\n      restartPolicy: OnFailure\n      containers:\n";
  y += container("merge", merge_cmd);
  y += volumes;
  const std::string path = (fs::path(o.outdir) / "job.yaml").string();
  writeFileAtomically(path, y);
  return {path};
}

/// `lensim dispatch`: fills in the default workdir and output, plans the parts and writes the
/// job files.
int runDispatch(Options& o) {
  const bool slurm = o.engine == "slurm";
  if (o.workdir.empty()) o.workdir = slurm ? fs::current_path().string() : "/data";
  if (o.output.empty())
    o.output = (fs::path(o.outdir) / (fs::path(o.scene).stem().string() + ".exr")).string();
  const std::vector<std::string> part_args = partArguments(o);
  render::parseDuration(o.checkpoint_every);
  fs::create_directories(fs::path(o.outdir) / "logs");
  fs::create_directories(fs::path(o.outdir) / "parts");
  const std::string name = dnsLabel(fs::path(o.scene).stem().string());
  const std::vector<std::string> written = slurm ? writeSlurmJobs(o, part_args, name)
                                                : writeKubernetesJobs(o, part_args, name);
  if (!lensim::quiet())
    for (const std::string& w : written) logInfo(fmt::format("wrote {}", w));
  return 0;
}

}  // namespace

void registerDispatchCommand(CLI::App& app, Action& action) {
  auto o = std::make_shared<Options>();
  CLI::App* d = app.add_subcommand(
      "dispatch",
      "Write Slurm or Kubernetes job files that render a scene as N parts and merge them");
  d->add_option("scene", o->scene, "Scene file (.pbrt), as the jobs will see it from --workdir")
      ->required();
  d->add_option("--engine", o->engine, "slurm (array job) or kubernetes (Indexed Job)")
      ->required()
      ->check(CLI::IsMember({"slurm", "kubernetes"}));
  d->add_option("--jobs", o->jobs, "Number of parts (array tasks / completion indices)")
      ->required()
      ->check(CLI::PositiveNumber);
  d->add_option("--split", o->split,
                "tiles (each job renders a tile with every sample) or samples (each job takes a "
                "slice of every pixel's samples); default tiles")
      ->check(CLI::IsMember({"tiles", "samples"}));
  d->add_option("--outdir", o->outdir,
                "Directory for the job files, logs and parts (default lensim-jobs)");
  d->add_option("--output", o->output, "Merged image (default OUTDIR/SCENE.exr)");
  d->add_option("--workdir", o->workdir,
                "Directory the jobs run in; relative paths are from there (default: the current "
                "directory for slurm, /data, the volume's mount, for kubernetes)");
  d->add_option("--lensim", o->lensim, "The lensim command on the nodes (default lensim)");
  d->add_option("--threads", o->threads,
                "Threads per part (default: the task's CPUs on Slurm, all cores otherwise)");
  d->add_option("--spp", o->spp, "Samples per pixel (overrides the scene's)");
  auto* seed = d->add_option("--seed", o->seed, "Sampler seed (overrides the scene's)");
  d->add_option("--checkpoint-every", o->checkpoint_every,
                "Checkpoint interval of each part, so preempted parts resume (default 60s)");
  d->add_option("--render-args", o->render_args,
                "More lensim render arguments for every part, as shell words");
  d->add_option("--partition", o->partition, "Slurm partition");
  d->add_option("--time", o->time_limit, "Slurm time limit per part (e.g. 02:00:00)");
  d->add_option("--cpus-per-task", o->cpus_per_task, "Slurm CPUs per part");
  d->add_option("--image", o->image, "Kubernetes: container image with lensim (docs/cluster.md)");
  d->add_option("--pvc", o->pvc,
                "Kubernetes: PersistentVolumeClaim with the scene, mounted at --workdir "
                "(default lensim-data)");
  d->add_option("--parallelism", o->parallelism, "Kubernetes: parts running at once (default all)");
  d->add_option("--cpu", o->cpu_request, "Kubernetes: CPU request per part (e.g. 8)");
  d->callback([o, seed, &action]() {
    o->has_seed = seed->count() > 0;
    action = [o]() -> int { return runDispatch(*o); };
  });
}

}  // namespace lensim::cmd
