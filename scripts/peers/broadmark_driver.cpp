// broadmark_driver: times one of Broadmark's CPU broadphases (Serpa &
// Rodrigues, CGF 2020) on a .aabbs stream, the way Broadmark's own loop
// (AppMain.cpp, BroadphaseInterface::ExecuteAndMeasure) times a frame: its
// UpdateObjects, CleanCache, UpdateStructures and SearchOverlaps, i.e. the new
// AABBs in, the search and the pair list out.  Stored frame 0 goes to
// Initialize, untimed, as in Broadmark; stored frames 1..F are frames.
//
// Each repeat runs the whole stream in a fresh algorithm; its figure is the
// median frame among stored frames >= --warmup (overlap_bench_broadphase's
// rule, so both time the same frames); a result is the median over repeats.
// The frames are read into memory first (Broadmark's Scene reader, which also
// widens the world AABB by 1.1 as Broadmark does), so no file I/O is timed.
//
// Pairs: every frame's reported count (the pair list's size, duplicates
// included: the grids report a pair once per shared cell) and, in the first
// repeat and untimed, its distinct pairs, written by --pairs-out as
// overlap pairs writes them (frame,a,b with a < b), to compare with an exact
// finder.  DBVT and AxisSweep keep Bullet's persistent pair cache, read
// through the subclasses below.
//
// Bad input: the option or file and the problem on stderr, exit 2, nothing
// written.  Broadmark's code and settings are used as they are (defaults of
// Core/Settings.h), except m_numThreads (--threads).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

#include "Broadphase/Algorithms/BF/BF.h"
#include "Broadphase/Algorithms/DBVT/DBVT.h"
#include "Broadphase/Algorithms/Grid/Grid.h"
#include "Broadphase/Algorithms/KD/KD.h"
#include "Broadphase/Algorithms/Tracy/Tracy.h"
#include "Broadphase/Algorithms/Tracy/Tracy_Parallel.h"
#include "Broadphase/Algorithms/iSAP/AxisSweep.h"
#include "Dependencies/Bullet2/btAxisSweep3.h"
#include "Dependencies/Bullet3/Bullet3Collision/BroadPhaseCollision/b3DynamicBvhBroadphase.h"

// Last, between SIMD.h (included above) and the SAP headers: see simd_loads.h.
#include "simd_loads.h"
//
#include "Broadphase/Algorithms/SAP/SAP.h"
#undef IsGreater

#define DOCTEST_CONFIG_IMPLEMENT
#include "Dependencies/doctest.h"

namespace {

using Clock = std::chrono::steady_clock;
using IdPairs = std::vector<std::pair<int, int>>;
constexpr const char* kProgram = "broadmark_driver";

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// An algorithm whose pairs live outside Broadmark's OverlapCache.
struct ListsPairs {
  virtual ~ListsPairs() = default;
  virtual void listPairs(IdPairs& pairs) = 0;
};

// Bullet 3's DBVT: pairs are (uid, uid), uid = index + 1 (DBVT.cpp).
template <class Dbvt>
class ListedDbvt : public Dbvt, public ListsPairs {
 public:
  void listPairs(IdPairs& pairs) override {
    const b3BroadphasePairArray& array =
        this->m_broadphase->getOverlappingPairCache()->getOverlappingPairArray();
    for (int i = 0; i < array.size(); ++i) pairs.emplace_back(array[i].x - 1, array[i].y - 1);
  }
};

// Bullet 2's 32-bit axis sweep: pairs are proxies, indexed by m_proxies.
class ListedAxisSweep : public AxisSweep, public ListsPairs {
 public:
  void listPairs(IdPairs& pairs) override {
    if (index_.empty()) {
      for (size_t i = 0; i < m_settings.m_numberOfObjects; ++i) index_[m_proxies[i]] = int(i);
    }
    const btBroadphasePairArray& array =
        m_broadphase->getOverlappingPairCache()->getOverlappingPairArray();
    for (int i = 0; i < array.size(); ++i) {
      pairs.emplace_back(index_.at(array[i].m_pProxy0), index_.at(array[i].m_pProxy1));
    }
  }

 private:
  std::unordered_map<const btBroadphaseProxy*, int> index_;
};

using Factory = std::function<std::unique_ptr<BroadphaseInterface>()>;
template <class Algorithm>
Factory make() {
  return [] { return std::make_unique<Algorithm>(); };
}

// Broadmark's CPU algorithms under Core/Algorithm.cpp's names ("DBVT F" may
// be given as DBVT_F).  CGAL and the GPU ones are not built.
const std::vector<std::pair<std::string, Factory>>& catalogue() {
  static const std::vector<std::pair<std::string, Factory>> algorithms = {
      {"BF", make<BF>()},
      {"BF_Parallel", make<BF_Parallel>()},
      {"BF_SSE", make<BF_SSE>()},
      {"BF_AVX", make<BF_AVX>()},
      {"BF_SSE_Parallel", make<BF_SSE_Parallel>()},
      {"BF_AVX_Parallel", make<BF_AVX_Parallel>()},
      {"SAP", make<SAP>()},
      {"SAP_Parallel", make<SAP_Parallel>()},
      {"SAP_SSE", make<SAP_SSE>()},
      {"SAP_AVX", make<SAP_AVX>()},
      {"SAP_SSE_Parallel", make<SAP_SSE_Parallel>()},
      {"SAP_AVX_Parallel", make<SAP_AVX_Parallel>()},
      {"AxisSweep", make<ListedAxisSweep>()},
      {"Grid_2D", make<Grid_2D>()},
      {"Grid_3D", make<Grid_3D>()},
      {"Grid_2D_SAP", make<Grid_2D_SAP>()},
      {"Grid_3D_SAP", make<Grid_3D_SAP>()},
      {"Grid_2D_Parallel", make<Grid_2D_Parallel>()},
      {"Grid_3D_Parallel", make<Grid_3D_Parallel>()},
      {"Grid_2D_SAP_Parallel", make<Grid_2D_SAP_Parallel>()},
      {"Grid_3D_SAP_Parallel", make<Grid_3D_SAP_Parallel>()},
      {"Tracy", make<Tracy>()},
      {"Tracy_Parallel", make<Tracy_Parallel>()},
      {"DBVT D", make<ListedDbvt<DBVT_D>>()},
      {"DBVT F", make<ListedDbvt<DBVT_F>>()},
      {"KD", make<KD>()},
  };
  return algorithms;
}

// Names a listed object by the frame's AABB it holds: Broadmark's SAPs sort
// m_objects in place while UpdateObjects writes frame AABB i into slot i, so
// their m_id stops naming the box after the first frame (it does not change
// what they find or their time).  An AABB the frame does not hold (KD grows
// its boxes by m_margin) is named by m_id, which KD keeps right.
class BoxNames {
 public:
  explicit BoxNames(const std::vector<Aabb>& frame) {
    for (size_t i = 0; i < frame.size(); ++i) index_.emplace(key(frame[i]), int(i));
  }
  int operator()(const Object& object) const {
    const auto found = index_.find(key(object.m_aabb));
    return found == index_.end() ? object.m_id : found->second;
  }

 private:
  static std::string key(const Aabb& box) {
    return {reinterpret_cast<const char*>(&box), sizeof(Aabb)};
  }
  std::unordered_map<std::string, int> index_;
};

// The distinct pairs of the algorithm's current list, each (low id, high id), sorted.
IdPairs distinctPairs(BroadphaseInterface& algorithm, const std::vector<Aabb>& frame) {
  IdPairs pairs;
  if (auto* listed = dynamic_cast<ListsPairs*>(&algorithm)) {
    listed->listPairs(pairs);
  } else if (auto* cache = dynamic_cast<SimpleCache*>(algorithm.GetOverlaps())) {
    const BoxNames name(frame);
    for (const ObjectPair& pair : cache->m_overlaps)
      pairs.emplace_back(name(*pair.m_a), name(*pair.m_b));
  }
  for (auto& [a, b] : pairs) {
    if (a > b) std::swap(a, b);
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  if (values.size() % 2 == 1) return *middle;
  return (*middle + *std::max_element(values.begin(), middle)) / 2.0;
}

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

struct Stream {
  SceneHeader header{};                   // the world AABB as Broadmark's Scene leaves it (x 1.1)
  std::vector<std::vector<Aabb>> frames;  // F + 1 stored frames
};

// Checks the layout (docs/SCENES.md) before Broadmark's reader, whose checks
// abort, sees the file; then reads every frame with it.
Stream readStream(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw UsageError("--input " + path + ": cannot be opened");
  SceneHeader header{};
  file.read(reinterpret_cast<char*>(&header), sizeof(header));
  const auto size = std::filesystem::file_size(path);
  if (!file || header.m_numberOfObjects <= 0 || header.m_numberOfFrames <= 0 ||
      header.m_sceneName[127] != 0 || header.m_objectsType[127] != 0 ||
      size != sizeof(SceneHeader) + sizeof(Aabb) * std::uintmax_t(header.m_numberOfObjects) *
                                        (std::uintmax_t(header.m_numberOfFrames) + 1)) {
    throw UsageError("--input " + path + ": not a .aabbs stream (header or size, docs/SCENES.md)");
  }
  Scene scene(path.c_str());
  Stream stream;
  stream.header = scene.GetHeader();
  const size_t n = size_t(stream.header.m_numberOfObjects);
  for (int f = 0; f <= stream.header.m_numberOfFrames; ++f) {
    const SceneFrame& frame = scene.GetNextFrame();
    stream.frames.emplace_back(frame.m_aabbs, frame.m_aabbs + n);
  }
  return stream;
}

struct Options {
  std::string algorithm;
  std::string input;
  std::string out;
  std::string pairs_out;
  int warmup = 2;
  int repeats = 3;
  int threads = 2;
};

struct FramePairs {
  int frame;
  size_t reported;
  size_t distinct;
};

struct Result {
  std::vector<double> repeat_medians_ms, update_ms, clean_ms, structures_ms, search_ms;
  std::vector<FramePairs> pairs;  // first repeat, every frame
  double reported_sum = 0;        // over measured frames of every repeat
  double measured = 0;
};

// One replay of the stream in a fresh algorithm; the first also lists pairs.
void replay(const Factory& factory, const InflatedSettings& settings, const Stream& stream,
            const Options& options, int repeat, Result& result, std::ofstream* pairs_out) {
  std::unique_ptr<BroadphaseInterface> algorithm = factory();
  algorithm->Initialize(settings, SceneFrame{const_cast<Aabb*>(stream.frames[0].data())});
  std::vector<double> total, update, clean, structures, search;
  for (size_t f = 1; f < stream.frames.size(); ++f) {
    const SceneFrame frame{const_cast<Aabb*>(stream.frames[f].data())};
    const Clock::time_point start = Clock::now();
    algorithm->PreUpdateObjects();
    algorithm->UpdateObjects(frame);
    algorithm->PostUpdateObjects();
    const double updated = msSince(start);
    algorithm->CleanCache();
    const double cleaned = msSince(start);
    algorithm->PreUpdateStructures();
    algorithm->UpdateStructures();
    algorithm->PostUpdateStructures();
    const double structured = msSince(start);
    algorithm->PreSearchOverlaps();
    algorithm->SearchOverlaps();
    algorithm->PostSearchOverlaps();
    const double searched = msSince(start);

    const size_t reported = algorithm->GetOverlaps()->Size();
    if (int(f) >= options.warmup) {
      total.push_back(searched);
      update.push_back(updated);
      clean.push_back(cleaned - updated);
      structures.push_back(structured - cleaned);
      search.push_back(searched - structured);
      result.reported_sum += double(reported);
      result.measured += 1;
    }
    if (repeat == 0) {
      const IdPairs pairs = distinctPairs(*algorithm, stream.frames[f]);
      result.pairs.push_back({int(f), reported, pairs.size()});
      if (pairs_out != nullptr) {
        for (const auto& [a, b] : pairs) *pairs_out << f << ',' << a << ',' << b << '\n';
      }
    }
  }
  if (dynamic_cast<Tracy_Parallel*>(algorithm.get()) != nullptr) {
    gTracyThreadPool.stop(true);  // Initialize placement-news the global pool again
  }
  result.repeat_medians_ms.push_back(median(total));
  result.update_ms.push_back(median(update));
  result.clean_ms.push_back(median(clean));
  result.structures_ms.push_back(median(structures));
  result.search_ms.push_back(median(search));
}

std::string firstLine(const char* path, const std::string& key) {
  std::ifstream file(path);
  for (std::string line; std::getline(file, line);) {
    if (key.empty() || line.rfind(key, 0) == 0) {
      const size_t colon = line.find(':');
      return key.empty() || colon == std::string::npos ? line : line.substr(colon + 2);
    }
  }
  return "unknown";
}

std::string fixed(double value, int decimals) {
  char text[48];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

void writeAtomically(const std::string& path, const std::string& text) {
  const std::string temporary = path + ".tmp";
  std::ofstream(temporary, std::ios::binary) << text;
  std::filesystem::rename(temporary, path);
}

// The result row (JSON): medians over repeats, pairs per measured frame.
nlohmann::json resultRow(const std::string& algorithm, const Stream& stream, const Options& options,
                         const Result& result) {
  const int measured = stream.header.m_numberOfFrames + 1 - options.warmup;
  double distinct_sum = 0;
  for (const FramePairs& frame : result.pairs) {
    if (frame.frame >= options.warmup) distinct_sum += double(frame.distinct);
  }
  const auto [fastest, slowest] =
      std::minmax_element(result.repeat_medians_ms.begin(), result.repeat_medians_ms.end());
  return {{"algorithm", algorithm},
          {"n", stream.header.m_numberOfObjects},
          {"stream", options.input},
          {"frames", measured},
          {"warmup", options.warmup},
          {"repeats", options.repeats},
          {"threads", options.threads},
          {"median_ms", median(result.repeat_medians_ms)},
          {"min_ms", *fastest},
          {"max_ms", *slowest},
          {"repeat_medians_ms", result.repeat_medians_ms},
          {"update_ms", median(result.update_ms)},
          {"clean_ms", median(result.clean_ms)},
          {"structures_ms", median(result.structures_ms)},
          {"search_ms", median(result.search_ms)},
          {"pairs_mean", result.reported_sum / result.measured},
          {"distinct_pairs_mean", distinct_sum / measured}};
}

std::string resultCsv(const nlohmann::json& machine, const nlohmann::json& row,
                      const std::string& command) {
  std::string csv = "# " + machine["cpu"].get<std::string>() + ", " +
                    std::to_string(machine["hardware_threads"].get<unsigned>()) + " threads, " +
                    BROADMARK_FLAGS + ", Broadmark " + BROADMARK_COMMIT + "; command: " + command +
                    '\n';
  csv +=
      "# time per frame: Broadmark's UpdateObjects + CleanCache + UpdateStructures + "
      "SearchOverlaps; median of the frames >= warmup per repeat (fresh algorithm), then over "
      "repeats\n"
      "# pairs_mean: reported pairs per measured frame (duplicates included); "
      "distinct_pairs_mean: distinct pairs per measured frame (first repeat)\n"
      "algorithm,n,frames,warmup,repeats,threads,median_ms,min_ms,max_ms,update_ms,clean_ms,"
      "structures_ms,search_ms,pairs_mean,distinct_pairs_mean,stream\n";
  csv += row["algorithm"].get<std::string>();
  for (const char* key : {"n", "frames", "warmup", "repeats", "threads"}) {
    csv += ',' + row[key].dump();
  }
  for (const char* key :
       {"median_ms", "min_ms", "max_ms", "update_ms", "clean_ms", "structures_ms", "search_ms"}) {
    csv += ',' + fixed(row[key].get<double>(), 4);
  }
  return csv + ',' + fixed(row["pairs_mean"].get<double>(), 1) + ',' +
         fixed(row["distinct_pairs_mean"].get<double>(), 1) + ',' +
         row["stream"].get<std::string>() + '\n';
}

int run(const Options& options, const std::string& command) {
  const auto found = std::find_if(catalogue().begin(), catalogue().end(), [&](const auto& entry) {
    return entry.first == options.algorithm;
  });
  if (found == catalogue().end())
    throw UsageError("--algo " + options.algorithm + ": not one of --list");
  const std::string load_before = firstLine("/proc/loadavg", "");
  const Stream stream = readStream(options.input);
  if (options.warmup > stream.header.m_numberOfFrames) {
    throw UsageError("--warmup " + std::to_string(options.warmup) + ": leaves no frame of " +
                     options.input + "'s " + std::to_string(stream.header.m_numberOfFrames + 1));
  }
  for (const std::string& path : {options.out + ".csv", options.out + ".json"}) {
    if (!std::ofstream(path + ".tmp"))
      throw UsageError("--out " + options.out + ": cannot write " + path);
    std::filesystem::remove(path + ".tmp");
  }

  Settings settings;
  settings.m_inputScene = options.input;
  settings.m_algorithm = settings.m_algorithm_prettyName = found->first;
  settings.m_numThreads = options.threads;
  const InflatedSettings inflated(settings, stream.header);

  std::unique_ptr<std::ofstream> pairs_out;
  if (!options.pairs_out.empty())
    pairs_out = std::make_unique<std::ofstream>(options.pairs_out + ".tmp");
  if (pairs_out) *pairs_out << "frame,a,b\n";
  Result result;
  for (int repeat = 0; repeat < options.repeats; ++repeat) {
    replay(found->second, inflated, stream, options, repeat, result,
           repeat == 0 ? pairs_out.get() : nullptr);
    std::fprintf(stderr, "%s: %s n=%d repeat %d/%d: %.3f ms/frame\n", kProgram,
                 found->first.c_str(), stream.header.m_numberOfObjects, repeat + 1, options.repeats,
                 result.repeat_medians_ms.back());
  }
  if (pairs_out) {
    pairs_out->close();
    std::filesystem::rename(options.pairs_out + ".tmp", options.pairs_out);
  }

  const nlohmann::json machine = {{"cpu", firstLine("/proc/cpuinfo", "model name")},
                                  {"hardware_threads", std::thread::hardware_concurrency()},
                                  {"compiler", BROADMARK_FLAGS},
                                  {"broadmark_commit", BROADMARK_COMMIT},
                                  {"driver_commit", OVERLAP_COMMIT},
                                  {"load_average_before", load_before},
                                  {"load_average_after", firstLine("/proc/loadavg", "")}};
  const nlohmann::json row = resultRow(found->first, stream, options, result);
  nlohmann::json frames = nlohmann::json::array();
  for (const FramePairs& frame : result.pairs) {
    frames.push_back(
        {{"frame", frame.frame}, {"reported", frame.reported}, {"distinct", frame.distinct}});
  }
  const nlohmann::json json = {{"machine", machine},
                               {"command", command},
                               {"settings", inflated},
                               {"row", row},
                               {"pairs_per_frame", frames}};
  const std::string csv = resultCsv(machine, row, command);
  writeAtomically(options.out + ".csv", csv);
  writeAtomically(options.out + ".json", json.dump(2) + '\n');
  std::fprintf(stderr, "%s: wrote %s.csv and %s.json\n", kProgram, options.out.c_str(),
               options.out.c_str());
  return 0;
}

std::string quotedCommand(int argc, char** argv) {
  std::string command;
  for (int i = 0; i < argc; ++i) {
    const std::string argument = argv[i];
    const bool plain =
        !argument.empty() && argument.find_first_of(" \t\"'$\\") == std::string::npos;
    command += (i > 0 ? " " : "") + (plain ? argument : '\'' + argument + '\'');
  }
  return command;
}

}  // namespace

int main(int argc, char** argv) {
  initializeDocTestForAssertionsOutOfTestCases();
  CLI::App app{"Times one of Broadmark's CPU broadphases on a .aabbs stream", kProgram};
  Options options;
  bool list = false;
  app.add_flag("--list", list, "print the algorithms and stop");
  app.add_option("--algo", options.algorithm,
                 "Broadmark's name, e.g. SAP_AVX_Parallel, KD, 'DBVT F'");
  app.add_option("--input", options.input, "the .aabbs stream")->check(CLI::ExistingFile);
  app.add_option("--out", options.out, "results: OUT.csv and OUT.json");
  app.add_option("--warmup", options.warmup, "first stored frames left out of the figures")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--repeats", options.repeats, "replays of the stream, each in a fresh algorithm")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--threads", options.threads, "Broadmark's m_numThreads")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  app.add_option("--pairs-out", options.pairs_out, "first repeat's distinct pairs as frame,a,b");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    if (error.get_exit_code() == 0) return app.exit(error);  // --help
    std::fprintf(stderr, "%s: %s (see --help)\n", kProgram, error.what());
    return 2;
  }
  if (list) {
    for (const auto& entry : catalogue()) std::printf("%s\n", entry.first.c_str());
    return 0;
  }
  try {
    for (const auto& [value, name] :
         {std::pair{&options.algorithm, "--algo"}, std::pair{&options.input, "--input"},
          std::pair{&options.out, "--out"}}) {
      if (value->empty()) throw UsageError(std::string(name) + ": required");
    }
    if (options.algorithm.rfind("DBVT_", 0) == 0) options.algorithm[4] = ' ';
    return run(options, quotedCommand(argc, argv));
  } catch (const UsageError& error) {
    std::fprintf(stderr, "%s: %s\n", kProgram, error.what());
    return 2;
  }
}
