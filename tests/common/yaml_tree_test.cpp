// rollstep::yaml: the tree every configuration loader reads, parsed by libyaml. Malformed
// text is a YamlError with line and column; what yaml-cpp 0.7 looped forever on is parsed
// or refused at once; nodes keep their kind, text, style and position.
#include "rollstep/common/yaml_tree.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace rollstep::yaml {
namespace {

std::string errorOf(const std::string& text) {
  try {
    Document::parse(text);
  } catch (const YamlError& e) {
    return e.what();
  }
  return "";
}

TEST(YamlTree, BuildsKindsTextsAndPositions) {
  const Document doc = Document::parse(
      "# a comment\n"
      "a: 1\n"
      "b: 'quoted'\n"
      "c: [x, ~, null]\n"
      "d:\n"
      "  e: -2.5e3\n"
      "f:\n"
      "g: !!str 7\n");
  const Node root = doc.root();
  ASSERT_TRUE(root.isMapping());
  ASSERT_EQ(root.size(), 6u);
  EXPECT_EQ(root.key(0).scalar(), "a");
  EXPECT_EQ(root.key(0).line(), 2);
  EXPECT_EQ(root.key(0).column(), 1);
  EXPECT_EQ(root.value(0).column(), 4);
  int i = 0;
  EXPECT_TRUE(root.value(0).toInt(i));
  EXPECT_EQ(i, 1);
  EXPECT_TRUE(root.value(1).isScalar());
  EXPECT_FALSE(root.value(1).plain());
  EXPECT_EQ(root.value(1).scalar(), "quoted");
  const Node c = root.value(2);
  ASSERT_TRUE(c.isSequence());
  ASSERT_EQ(c.size(), 3u);
  EXPECT_TRUE(c.item(0).isScalar());
  EXPECT_TRUE(c.item(1).isNull());
  EXPECT_TRUE(c.item(2).isNull());
  EXPECT_EQ(c.line(), 4);
  const Node d = root.value(3);
  ASSERT_TRUE(d.isMapping());
  double x = 0.0;
  EXPECT_TRUE(d.value(0).toDouble(x));
  EXPECT_EQ(x, -2500.0);
  EXPECT_EQ(d.key(0).line(), 6);
  EXPECT_TRUE(root.value(4).isNull());  // "f:" without a value
  // A tagged or quoted scalar is text, never a number or null.
  EXPECT_EQ(root.value(5).tag(), "tag:yaml.org,2002:str");
  EXPECT_FALSE(root.value(5).plain());
  EXPECT_FALSE(root.value(5).toInt(i));
  EXPECT_TRUE(Document::parse("'null'").root().isScalar());
  EXPECT_TRUE(Document::parse("").root().isNull());
  EXPECT_TRUE(Document::parse("# only a comment\n").root().isNull());
  EXPECT_TRUE(Document::parse("---\n...\n").root().isNull());
  EXPECT_EQ(Document::parse("just text").root().scalar(), "just text");
}

TEST(YamlTree, RepeatedKeysAreKeptInOrderForTheLoaderToRefuse) {
  const Document doc = Document::parse("a: 1\nb: 2\na: 3\n");
  ASSERT_EQ(doc.root().size(), 3u);
  EXPECT_EQ(doc.root().key(2).scalar(), "a");
  EXPECT_EQ(doc.root().key(2).line(), 3);
}

TEST(YamlTree, AliasesShareTheAnchoredNodeWithoutCopies) {
  const Document doc = Document::parse("a: &x {k: 1}\nb: *x\nc: &s 5\nd: *s\n");
  const Node root = doc.root();
  EXPECT_TRUE(root.value(1).isMapping());
  EXPECT_EQ(root.value(1).line(), 1);  // the anchored node itself
  EXPECT_EQ(root.value(3).scalar(), "5");
  // Billion laughs: ten levels of ten aliases each would expand to 10^10 nodes.
  std::string laughs = "l0: &l0 [lol]\n";
  for (int level = 1; level <= 10; ++level) {
    laughs += "l" + std::to_string(level) + ": &l" + std::to_string(level) + " [";
    for (int k = 0; k < 10; ++k) laughs += (k ? ", *l" : "*l") + std::to_string(level - 1);
    laughs += "]\n";
  }
  const Document big = Document::parse(laughs);
  EXPECT_EQ(big.root().size(), 11u);
  EXPECT_EQ(big.root().value(10).size(), 10u);
  EXPECT_NE(errorOf("a: *nothing\n").find("unknown alias *nothing"), std::string::npos);
}

TEST(YamlTree, ScalarConversionsAreStrict) {
  const auto number = [](const std::string& text, double& v) {
    return Document::parse("v: " + text).root().value(0).toDouble(v);
  };
  double v = 0.0;
  for (const std::string ok : {"0", "-3", "+4.5", "1e-8", "2.E3", ".5", "-0.25e+2"}) {
    EXPECT_TRUE(number(ok, v)) << ok;
    EXPECT_EQ(v, std::strtod(ok.c_str(), nullptr)) << ok;
  }
  EXPECT_TRUE(number(".inf", v) && std::isinf(v) && v > 0);
  EXPECT_TRUE(number("-.Inf", v) && std::isinf(v) && v < 0);
  EXPECT_TRUE(number(".NaN", v) && std::isnan(v));
  for (const std::string bad :
       {"0x10", "1e", "e5", "1.2.3", "12abc", "inf", "nan", "'1'", "+-1", "1_000", "--1", "."}) {
    EXPECT_FALSE(number(bad, v)) << bad;
  }
  const auto integer = [](const std::string& text, int& i) {
    return Document::parse("v: " + text).root().value(0).toInt(i);
  };
  int i = 0;
  EXPECT_TRUE(integer("-2147483648", i) && i == -2147483648);
  for (const std::string bad : {"2147483648", "1.0", "1e3", ".inf", "0x1f", "", "\"3\""}) {
    EXPECT_FALSE(integer(bad, i)) << bad;
  }
  bool b = false;
  EXPECT_TRUE(Document::parse("True").root().toBool(b) && b);
  EXPECT_TRUE(Document::parse("false").root().toBool(b) && !b);
  EXPECT_FALSE(Document::parse("yes").root().toBool(b));
  EXPECT_FALSE(Document::parse("'true'").root().toBool(b));
}

TEST(YamlTree, MalformedTextIsAnErrorWithLineAndColumn) {
  EXPECT_EQ(errorOf("a: [1, 2\n"),
            "line 2, column 1: did not find expected ',' or ']' while parsing a flow sequence");
  for (const std::string text :
       {"a: 1\n,b: 2\n", "a: ]\n", "{a: 1\n", "a: 'x\n", "\t- a\n", "a: 1\n b: 2\n c"}) {
    EXPECT_EQ(errorOf(text).rfind("line ", 0), 0u) << text;
  }
  EXPECT_EQ(errorOf("a: 1\n---\nb: 2\n"),
            "holds more than one YAML document (the second starts on line 2)");
}

TEST(YamlTree, TextsThatHungYamlCppAreParsedOrRefusedAtOnce) {
  // Every input on which yaml-cpp 0.7 looped forever (fuzz/regressions/*, and the classes
  // they stand for: a ',' where a document's node or the token after it should be).
  for (const std::string text : {",",
                                 ",a: 1",
                                 " ,",
                                 "\t,x",
                                 "\n\n,",
                                 "# comment\n,",
                                 "---\n,",
                                 "--- ,",
                                 "&a ,",
                                 "!t ,",
                                 "!!str ,",
                                 "&a !t ,",
                                 "!,",
                                 "&x:,",
                                 "%YAML 1.2\n---\n,",
                                 "a: 1\n---\n,",
                                 "'',",
                                 "\"\",",
                                 ">\n,",
                                 "|-\n,",
                                 "'?1{1',",
                                 "!w ,,l",
                                 "!w ---\n!w ,,l",
                                 "[:",
                                 "{:",
                                 "{!\xdb:",
                                 "[[:"}) {
    std::string error;
    try {
      const Document doc = Document::parse(text);
      (void)doc.root().kind();
    } catch (const YamlError& e) {
      error = e.what();
    }
    // Either outcome is fine; reaching this line at all is the point (no hang).
    SUCCEED() << text << " -> " << error;
  }
}

TEST(YamlTree, NestingDeeperThanTheLimitIsRefusedInLinearTime) {
  // 100,000 '[' took libyaml 30 s (quadratic); refused at once, naming the line.
  EXPECT_EQ(errorOf("a: 1\nb: " + std::string(100000, '[') + "\n")
                .rfind("line 2: flow collections nested deeper than 64", 0),
            0u);
  EXPECT_EQ(errorOf("a: " + std::string(64, '[') + std::string(64, ']') + "\n"), "");
  // Brackets inside quoted scalars and comments do not count.
  EXPECT_EQ(errorOf("a: '" + std::string(100, '[') + "'\nb: \"" + std::string(100, '{') + "\"  # " +
                    std::string(100, '[') + "\n"),
            "");
  // Block nesting is bounded too.
  std::string block;
  for (int level = 0; level < 140; ++level) block += std::string(2 * level, ' ') + "k:\n";
  EXPECT_NE(errorOf(block).find("nested deeper than 128"), std::string::npos);
}

TEST(YamlTree, EveryYamlFileOfTheRepositoryParses) {
  int files = 0;
  const std::filesystem::path root = std::filesystem::path(ROLLSTEP_TEST_DATA_DIR) / "../..";
  for (auto it = std::filesystem::recursive_directory_iterator(root);
       it != std::filesystem::recursive_directory_iterator(); ++it) {
    const std::string name = it->path().filename().string();
    if (it->is_directory()) {
      if (name.rfind("build", 0) == 0 || name == ".git" || name == "fuzz" || name == "out") {
        it.disable_recursion_pending();
      }
      continue;
    }
    if (!it->is_regular_file() || it->path().extension() != ".yaml") continue;
    std::ifstream in(it->path());
    std::stringstream ss;
    ss << in.rdbuf();
    EXPECT_EQ(errorOf(ss.str()), "") << it->path();
    ++files;
  }
  EXPECT_GE(files, 1);
}

}  // namespace
}  // namespace rollstep::yaml
