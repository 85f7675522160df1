// The documentation can rot like code: a moved file leaves a dead link, a renamed program leaves a
// command that no longer runs, and the root README grows back into a log. These tests read every
// markdown file of the repository and fail on:
// - a relative link [x](path) or [x](path#anchor) that does not resolve from the file's folder;
// - a repository path in backticks (starting with engine/, shadows/, shaders/, sample_world/,
//   tests/ or tools/) that does not exist;
// - a build/bin/<name> that no CMakeLists.txt defines as an executable target;
// - a root README.md over 200 lines, or with a commit hash or an issue reference in it.
// The checkers are tested on synthetic text first, so each is shown to fail.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace fs = std::filesystem;

namespace {

const fs::path kRoot = CSM_SOURCE_DIR;

// The folders whose markdown is checked (with the root's own *.md files), and the prefixes that
// make a backtick span a repository path.
const std::vector<std::string> kTopFolders = {"engine",       "shadows", "shaders",
                                              "sample_world", "tests",   "tools"};

// Generated output that is not documentation: the sweep's result tables, rewritten by
// `csm_tradeoff --out tools/tradeoff/results`.
const std::vector<std::string> kSkippedDirs = {"tools/tradeoff/results"};

// Paths the docs name that a command writes rather than the repository keeps, under a top-level
// folder. Paths under build/ and out/ (test artefacts, a run's screenshots, report.json) are
// never checked: they start with no top-level folder of the repository. Keep this list short;
// each entry says what writes it.
const std::vector<std::string> kGeneratedPaths = {};

struct Finding {
  std::string file;
  int line = 0;
  std::string what;
};

std::string toString(const std::vector<Finding>& findings) {
  std::ostringstream out;
  for (const Finding& f : findings) out << f.file << ":" << f.line << ": " << f.what << "\n";
  return out.str();
}

std::string readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

int lineAt(const std::string& text, std::size_t pos) {
  return 1 +
         static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n'));
}

bool startsWith(std::string_view s, std::string_view prefix) {
  return s.substr(0, prefix.size()) == prefix;
}

// Every *.md of the root folder, and every *.md under the top-level folders, except build
// folders, .git and the generated directories above.
std::vector<fs::path> markdownFiles(const fs::path& root) {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(root)) {
    if (e.is_regular_file() && e.path().extension() == ".md") files.push_back(e.path());
  }
  for (const std::string& top : kTopFolders) {
    const fs::path dir = root / top;
    if (!fs::is_directory(dir)) continue;
    for (auto it = fs::recursive_directory_iterator(dir); it != fs::recursive_directory_iterator();
         ++it) {
      const std::string rel = fs::relative(it->path(), root).generic_string();
      const std::string name = it->path().filename().string();
      if (it->is_directory()) {
        const bool skipped =
            std::find(kSkippedDirs.begin(), kSkippedDirs.end(), rel) != kSkippedDirs.end();
        if (startsWith(name, "build") || startsWith(name, ".git") || skipped) {
          it.disable_recursion_pending();
        }
        continue;
      }
      if (it->is_regular_file() && it->path().extension() == ".md") files.push_back(it->path());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

// The text with fenced code blocks (```) blanked, newlines kept so line numbers still match.
std::string withoutFences(const std::string& text) {
  std::string out = text;
  bool inFence = false;
  std::size_t lineStart = 0;
  while (lineStart < out.size()) {
    std::size_t lineEnd = out.find('\n', lineStart);
    if (lineEnd == std::string::npos) lineEnd = out.size();
    const std::string_view line(out.data() + lineStart, lineEnd - lineStart);
    const std::size_t first = line.find_first_not_of(' ');
    const bool fence = first != std::string_view::npos && line.substr(first, 3) == "```";
    if (fence || inFence)
      std::fill(out.begin() + static_cast<long>(lineStart),
                out.begin() + static_cast<long>(lineEnd), ' ');
    if (fence) inFence = !inFence;
    lineStart = lineEnd + 1;
  }
  return out;
}

// The text with inline code spans (`...`) blanked as well.
std::string withoutCode(const std::string& text) {
  std::string out = withoutFences(text);
  std::size_t open = out.find('`');
  while (open != std::string::npos) {
    const std::size_t close = out.find('`', open + 1);
    if (close == std::string::npos) break;
    if (out.find('\n', open) < close) {  // a lone backtick: spans do not cross lines here
      open = out.find('`', open + 1);
      continue;
    }
    std::fill(out.begin() + static_cast<long>(open), out.begin() + static_cast<long>(close) + 1,
              ' ');
    open = out.find('`', close + 1);
  }
  return out;
}

// Relative link targets of `text` (a markdown file in `dir`) that do not resolve to a file or
// folder. Web and mail links and links within the page (#anchor) are not checked; a #anchor
// after a path is dropped.
std::vector<Finding> brokenLinks(const std::string& text, const fs::path& dir,
                                 const std::string& name, std::size_t* checked = nullptr) {
  std::vector<Finding> found;
  const std::string prose = withoutCode(text);
  static const std::regex target(R"(^\(<?([^)\s>]+)>?(\s+"[^"]*")?\))");
  for (std::size_t pos = prose.find("]("); pos != std::string::npos;
       pos = prose.find("](", pos + 2)) {
    std::smatch m;
    const std::string rest = prose.substr(pos + 1, 512);
    if (!std::regex_search(rest, m, target)) continue;
    std::string link = m[1].str();
    if (startsWith(link, "http://") || startsWith(link, "https://") ||
        startsWith(link, "mailto:") || startsWith(link, "#")) {
      continue;
    }
    if (checked != nullptr) ++*checked;
    const std::size_t hash = link.find('#');
    if (hash != std::string::npos) link.resize(hash);
    if (link.empty() || !fs::exists(dir / link)) {
      found.push_back({name, lineAt(prose, pos), "broken link: " + m[1].str()});
    }
  }
  return found;
}

// The repository path a backtick span names, or "" when it names none: its first word, if it
// starts with a top-level folder, less a trailing :line and punctuation, and cut before the first
// glob-ish character (*, ?, {, [, <, an ellipsis) to the folder that holds it.
std::string repoPathOf(const std::string& span) {
  std::string word = span.substr(0, span.find_first_of(" \t"));
  bool isRepoPath = false;
  for (const std::string& top : kTopFolders) isRepoPath = isRepoPath || startsWith(word, top + "/");
  if (!isRepoPath) return "";
  static const std::regex lineSuffix(R"(:\d+(-\d+)?$)");
  const auto trimPunctuation = [&word] {
    while (!word.empty() && std::string_view(",.;:)'\"").find(word.back()) != std::string::npos) {
      word.pop_back();
    }
  };
  trimPunctuation();
  word = std::regex_replace(word, lineSuffix, "");
  trimPunctuation();
  std::size_t glob = word.find_first_of("*?{[<");
  glob = std::min(glob, word.find("\xE2\x80\xA6"));  // U+2026, the ellipsis
  glob = std::min(glob, word.find("..."));
  if (glob != std::string::npos) {
    const std::size_t slash = word.rfind('/', glob);
    word = slash == std::string::npos ? "" : word.substr(0, slash);
  }
  return word;
}

bool isGenerated(const std::string& path) {
  return std::find(kGeneratedPaths.begin(), kGeneratedPaths.end(), path) != kGeneratedPaths.end();
}

// Repository paths in backticks (outside fenced blocks) that do not exist under `root`.
std::vector<Finding> missingPaths(const std::string& text, const fs::path& root,
                                  const std::string& name, std::size_t* checked = nullptr) {
  std::vector<Finding> found;
  const std::string prose = withoutFences(text);
  static const std::regex span("`([^`\n]+)`");
  for (auto it = std::sregex_iterator(prose.begin(), prose.end(), span);
       it != std::sregex_iterator(); ++it) {
    const std::string path = repoPathOf((*it)[1].str());
    if (path.empty()) continue;
    if (checked != nullptr) ++*checked;
    if (isGenerated(path) || fs::exists(root / path)) continue;
    found.push_back(
        {name, lineAt(prose, static_cast<std::size_t>(it->position(0))), "no such path: " + path});
  }
  return found;
}

// Every build/bin/<name> of the text, fenced commands included.
std::set<std::string> programsNamed(const std::string& text) {
  std::set<std::string> names;
  static const std::regex bin(R"(build/bin/([A-Za-z0-9_]+))");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), bin); it != std::sregex_iterator();
       ++it) {
    names.insert((*it)[1].str());
  }
  return names;
}

// Whether `name` is an executable target of the CMake sources: `add_executable(name` or a call
// `fn(name` of a function `fn` that some CMake file defines (csm_add_test and the like).
bool isExecutableTarget(const std::string& name, const std::string& cmakeText,
                        const std::set<std::string>& functions) {
  const std::regex call(R"(\b([A-Za-z_][A-Za-z0-9_]*)\(\s*)" + name + R"([\s)])");
  for (auto it = std::sregex_iterator(cmakeText.begin(), cmakeText.end(), call);
       it != std::sregex_iterator(); ++it) {
    const std::string fn = (*it)[1].str();
    if (fn == "add_executable" || functions.count(fn) != 0) return true;
  }
  return false;
}

std::set<std::string> cmakeFunctions(const std::string& cmakeText) {
  std::set<std::string> names;
  static const std::regex def(R"(\bfunction\(\s*([A-Za-z_][A-Za-z0-9_]*))");
  for (auto it = std::sregex_iterator(cmakeText.begin(), cmakeText.end(), def);
       it != std::sregex_iterator(); ++it) {
    names.insert((*it)[1].str());
  }
  return names;
}

// Every CMakeLists.txt and *.cmake of the repository (not build folders or .git), concatenated.
std::string cmakeSources(const fs::path& root) {
  std::string all;
  for (auto it = fs::recursive_directory_iterator(root); it != fs::recursive_directory_iterator();
       ++it) {
    const std::string name = it->path().filename().string();
    if (it->is_directory()) {
      if (startsWith(name, "build") || startsWith(name, ".") || name == "out") {
        it.disable_recursion_pending();
      }
      continue;
    }
    if (name == "CMakeLists.txt" || it->path().extension() == ".cmake") {
      all += readFile(it->path()) + "\n";
    }
  }
  return all;
}

// Commit-hash-like words outside URLs: 7 to 40 lowercase hex characters with at least one digit
// and one letter.
std::vector<Finding> hashLikeTokens(const std::string& text, const std::string& name) {
  std::vector<Finding> found;
  static const std::regex url(R"((https?|mailto):[^\s)>\]]+)");
  const std::string noUrls = std::regex_replace(text, url, " ");
  static const std::regex hex(R"(\b[0-9a-f]{7,40}\b)");
  for (auto it = std::sregex_iterator(noUrls.begin(), noUrls.end(), hex);
       it != std::sregex_iterator(); ++it) {
    const std::string w = it->str();
    const bool digit = w.find_first_of("0123456789") != std::string::npos;
    const bool letter = w.find_first_of("abcdef") != std::string::npos;
    if (digit && letter) {
      found.push_back({name, lineAt(noUrls, static_cast<std::size_t>(it->position(0))),
                       "commit-hash-like token: " + w});
    }
  }
  return found;
}

// Issue references: #<digits> or "issue <digits>", any case.
std::vector<Finding> issueReferences(const std::string& text, const std::string& name) {
  std::vector<Finding> found;
  static const std::regex issue(R"((#\d+)|(\bissues?\s+#?\d+))", std::regex::icase);
  for (auto it = std::sregex_iterator(text.begin(), text.end(), issue);
       it != std::sregex_iterator(); ++it) {
    found.push_back({name, lineAt(text, static_cast<std::size_t>(it->position(0))),
                     "issue reference: " + it->str()});
  }
  return found;
}

std::string relName(const fs::path& file) {
  return fs::relative(file, kRoot).generic_string();
}

// ---- The checkers on synthetic text: each finds what it is for, and passes what is right.

TEST(DocsCheckers, BrokenLinksAreFoundAndGoodOnesPass) {
  const std::string good =
      "See [the guide](shadows/README.md), [a part](shadows/docs/cache.md#tests), [the folder]"
      "(tools/bench), ![a picture\nover two lines](shadows/docs/images/flythrough_forest_overlay"
      ".png), [the web](https://example.org/x) and [a section](#set-up).";
  EXPECT_EQ(toString(brokenLinks(good, kRoot, "good.md")), "");
  const std::string bad = "Intro\n[gone](shadows/docs/no_such_page.md) and [x](nope#a)\n";
  const std::vector<Finding> found = brokenLinks(bad, kRoot, "bad.md");
  ASSERT_EQ(found.size(), 2u) << toString(found);
  EXPECT_EQ(found[0].line, 2);
  EXPECT_NE(found[0].what.find("no_such_page.md"), std::string::npos);
  // Links inside code are not links.
  EXPECT_EQ(toString(brokenLinks("`[x](nope)`\n```\n[y](nope)\n```\n", kRoot, "code.md")), "");
}

TEST(DocsCheckers, MissingRepositoryPathsAreFound) {
  const std::string good =
      "`shadows/README.md`, `shadows/shaders/csm.glsl:120`, `tools/bench/cache_flights.sh --frames "
      "40`, `tools/measure/\xE2\x80\xA6/bias_metrics.hpp`, `sample_world/`, "
      "`build/bin/whatever`, `csm/types.hpp` and `tools/tradeoff/results/fit_study.json`.";
  EXPECT_EQ(toString(missingPaths(good, kRoot, "good.md")), "");
  const std::vector<Finding> found =
      missingPaths("a\n`shadows/no_such_file.hpp` and `tests/nope/*.cpp`", kRoot, "bad.md");
  ASSERT_EQ(found.size(), 2u) << toString(found);
  EXPECT_EQ(found[0].line, 2);
  EXPECT_EQ(repoPathOf("tests/nope/*.cpp"), "tests/nope");
  EXPECT_EQ(repoPathOf("shadows/README.md:12,"), "shadows/README.md");
}

TEST(DocsCheckers, UnknownProgramsAreFound) {
  const std::string cmake =
      "function(csm_add_test name)\nendfunction()\nadd_executable(csm_real main.cpp)\n"
      "csm_add_test(real_tests LABELS unit)\ntarget_link_libraries(linked_only PRIVATE x)\n";
  const std::set<std::string> fns = cmakeFunctions(cmake);
  EXPECT_TRUE(isExecutableTarget("csm_real", cmake, fns));
  EXPECT_TRUE(isExecutableTarget("real_tests", cmake, fns));
  EXPECT_FALSE(isExecutableTarget("linked_only", cmake, fns));
  EXPECT_FALSE(isExecutableTarget("csm_gone", cmake, fns));
  EXPECT_FALSE(isExecutableTarget("csm_rea", cmake, fns));
  EXPECT_EQ(programsNamed("run `build/bin/csm_real --x` or build/bin/csm_gone"),
            (std::set<std::string>{"csm_gone", "csm_real"}));
}

TEST(DocsCheckers, HashesAndIssueReferencesAreFound) {
  EXPECT_EQ(hashLikeTokens("before 9efa1bf and c854553, hash 1218d89fa6be0054", "x").size(), 3u);
  EXPECT_EQ(toString(hashLikeTokens(
                "deadbeef, 1234567, 2048x2048, 0.00056, 1e10, flythrough_forest_overlay, "
                "https://github.com/a/b/commit/9efa1bf and Abcdef12",
                "x")),
            "");
  EXPECT_EQ(issueReferences("see #12 and Issue 15, issues 3; also issue #7", "x").size(), 4u);
  EXPECT_EQ(toString(issueReferences("C# and section 12, 2 issues remain", "x")), "");
}

// ---- The repository's own markdown.

TEST(Docs, TheMarkdownIsFound) {
  const std::vector<fs::path> files = markdownFiles(kRoot);
  std::set<std::string> names;
  for (const fs::path& f : files) names.insert(relName(f));
  EXPECT_GE(files.size(), 10u);
  for (const char* must : {"README.md", "shadows/README.md", "shadows/CHANGELOG.md",
                           "tests/README.md", "sample_world/README.md"}) {
    EXPECT_EQ(names.count(must), 1u) << must;
  }
  for (const std::string& n : names) {
    EXPECT_FALSE(startsWith(n, "tools/tradeoff/results/")) << n;
    EXPECT_FALSE(startsWith(n, "build")) << n;
  }
}

TEST(Docs, RelativeLinksResolve) {
  std::vector<Finding> all;
  std::size_t checked = 0;
  for (const fs::path& f : markdownFiles(kRoot)) {
    const std::vector<Finding> found =
        brokenLinks(readFile(f), f.parent_path(), relName(f), &checked);
    all.insert(all.end(), found.begin(), found.end());
  }
  EXPECT_GT(checked, 30u);
  EXPECT_TRUE(all.empty()) << toString(all);
}

TEST(Docs, RepositoryPathsInBackticksExist) {
  std::vector<Finding> all;
  std::size_t checked = 0;
  for (const fs::path& f : markdownFiles(kRoot)) {
    const std::vector<Finding> found = missingPaths(readFile(f), kRoot, relName(f), &checked);
    all.insert(all.end(), found.begin(), found.end());
  }
  EXPECT_GT(checked, 30u);
  EXPECT_TRUE(all.empty()) << toString(all);
}

TEST(Docs, BuildBinProgramsAreExecutableTargets) {
  const std::string cmake = cmakeSources(kRoot);
  const std::set<std::string> functions = cmakeFunctions(cmake);
  std::vector<Finding> all;
  std::size_t checked = 0;
  for (const fs::path& f : markdownFiles(kRoot)) {
    for (const std::string& name : programsNamed(readFile(f))) {
      ++checked;
      if (!isExecutableTarget(name, cmake, functions)) {
        all.push_back({relName(f), 0, "build/bin/" + name + " is no executable target"});
      }
    }
  }
  EXPECT_GT(checked, 5u);
  EXPECT_TRUE(all.empty()) << toString(all);
}

TEST(Docs, RootReadmeIsShortWithoutHashesOrIssueNumbers) {
  const std::string text = readFile(kRoot / "README.md");
  ASSERT_FALSE(text.empty());
  const auto lines = std::count(text.begin(), text.end(), '\n');
  EXPECT_LE(lines, 200) << "README.md has " << lines << " lines; details belong in the docs";
  EXPECT_EQ(toString(hashLikeTokens(text, "README.md")), "");
  EXPECT_EQ(toString(issueReferences(text, "README.md")), "");
}

}  // namespace
