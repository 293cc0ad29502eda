// The settings table: reads, checks and writes a struct's YAML by one table of fields.
#include "rollstep/common/settings_table.hpp"

#include <gtest/gtest.h>

#include <limits>

namespace rollstep::test_settings {

enum class Colour { Red, Green, Blue };
constexpr std::array<EnumName<Colour>, 3> enumNames(Colour) {
  return {{{Colour::Red, "red"}, {Colour::Green, "green"}, {Colour::Blue, "blue"}}};
}

struct Inner {
  double gain = 2.5;
  int count = 3;
};

struct Outer {
  double dt = 0.01;
  int steps = 10;
  bool enabled = true;
  Colour colour = Colour::Green;
  Eigen::Vector3d offset{0.1, 0.0, -0.2};
  std::vector<double> weights{1.0, 2.0};
  std::vector<std::string> names{"a", "b"};
  Inner inner;
};

settings::Table<Inner> innerTable() {
  return settings::Table<Inner>()
      .field("gain", &Inner::gain, "N/m", settings::Range::closed(0, 10))
      .field("count", &Inner::count, "", settings::Range::closed(1, 5));
}

const settings::Table<Outer>& outerTable() {
  static const settings::Table<Outer> table =
      settings::Table<Outer>()
          .field("dt", &Outer::dt, "s", settings::Range::leftOpen(0, 1))
          .field("steps", &Outer::steps, "", settings::Range::closed(1, 100))
          .field("enabled", &Outer::enabled)
          .field("colour", &Outer::colour)
          .field("offset", &Outer::offset, "m", settings::Range::closed(-1, 1))
          .field("weights", &Outer::weights, "", settings::Range::closed(0, 1e6))
          .field("names", &Outer::names)
          .section("inner", &Outer::inner, innerTable());
  return table;
}

Outer read(const std::string& text, const Outer& base = Outer{}) {
  return settings::readDocument(text, outerTable(), "test settings t.yaml: ", base);
}

std::string errorOf(const std::string& text) {
  try {
    read(text);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

bool same(const Outer& a, const Outer& b) {
  return a.dt == b.dt && a.steps == b.steps && a.enabled == b.enabled && a.colour == b.colour &&
         a.offset == b.offset && a.weights == b.weights && a.names == b.names &&
         a.inner.gain == b.inner.gain && a.inner.count == b.inner.count;
}

TEST(SettingsTable, AbsentKeysKeepTheirValuesAndGivenKeysAreRead) {
  EXPECT_TRUE(same(read(""), Outer{}));
  const Outer o = read(
      "dt: 0.5\nsteps: 7\nenabled: false\ncolour: blue\noffset: [1, -1, 0.5]\n"
      "weights: [3]\nnames: [x, y, z]\ninner:\n  gain: 4\n");
  EXPECT_EQ(o.dt, 0.5);
  EXPECT_EQ(o.steps, 7);
  EXPECT_FALSE(o.enabled);
  EXPECT_EQ(o.colour, Colour::Blue);
  EXPECT_EQ(o.offset, Eigen::Vector3d(1, -1, 0.5));
  EXPECT_EQ(o.weights, std::vector<double>{3});
  EXPECT_EQ(o.names, (std::vector<std::string>{"x", "y", "z"}));
  EXPECT_EQ(o.inner.gain, 4.0);
  EXPECT_EQ(o.inner.count, 3);  // not given: the default
  // Over another base (a file extending another): only the keys given change.
  Outer base;
  base.steps = 42;
  EXPECT_EQ(read("dt: 0.2\n", base).steps, 42);
  // An empty section keeps its values.
  EXPECT_TRUE(same(read("inner:\n"), Outer{}));
}

TEST(SettingsTable, ErrorsNameTheFileLineAndFullKeyPath) {
  struct Case {
    const char* text;
    const char* message;
  };
  const Case cases[] = {
      {"dt: 0.1\nspeed: 1\n",
       "line 2: unknown key 'speed' (known: dt, steps, enabled, colour, offset, weights, names, "
       "inner)"},
      {"inner:\n  gian: 1\n", "line 2: unknown key 'inner.gian' (known in inner: gain, count)"},
      {"dt: 0.1\ndt: 0.2\n", "line 2: dt: given twice (first on line 1)"},
      {"inner:\n  gain: 1\n  gain: 2\n", "line 3: inner.gain: given twice (first on line 2)"},
      {"dt: 0\n", "line 1: dt: 0 is outside (0, 1]"},
      {"dt: .nan\n", "line 1: dt: .nan is outside (0, 1]"},
      {"dt: fast\n", "line 1: dt: 'fast' is not a number"},
      {"dt: '0.1'\n", "line 1: dt: '0.1' is not a number (it is quoted or tagged)"},
      {"dt: [1]\n", "line 1: dt: expected a single number, got a list"},
      {"dt:\n", "line 1: dt: no value"},
      {"steps: 2.5\n", "line 1: steps: expected an integer, got '2.5'"},
      {"steps: 101\n", "line 1: steps: 101 is outside [1, 100]"},
      {"enabled: yes\n", "line 1: enabled: expected true or false, got 'yes'"},
      {"colour: pink\n", "line 1: colour: expected red, green or blue, got 'pink'"},
      {"colour: 'red'\n",
       "line 1: colour: expected red, green or blue, got 'red' (it is quoted or tagged)"},
      {"offset: [1, 2]\n", "line 1: offset: expected a list of 3 numbers, got a list of 2"},
      {"offset: [0, 0,\n  2]\n", "line 2: offset: 2 is outside [-1, 1]"},
      {"weights: 1\n", "line 1: weights: expected a list of numbers, got a value"},
      {"names: [a, a]\n", "line 1: names: 'a' given twice"},
      {"inner: 3\n", "line 1: inner: expected a mapping, got a value"},
      {"inner:\n  count: 0\n", "line 2: inner.count: 0 is outside [1, 5]"},
      {"- 1\n", "line 1: expected a mapping of key: value"},
      {"[a]: 1\n", "line 1: <key>: a key is not a plain name"},
  };
  for (const Case& c : cases) {
    const std::string e = errorOf(c.text);
    EXPECT_EQ(e.rfind("test settings t.yaml: ", 0), 0u) << c.text << " -> " << e;
    EXPECT_NE(e.find(c.message), std::string::npos) << c.text << " -> " << e;
  }
  EXPECT_NE(errorOf("dt: [1\n").find("test settings t.yaml: YAML error: line 2"), std::string::npos)
      << errorOf("dt: [1\n");
}

TEST(SettingsTable, WriteThenReadGivesEqualSettings) {
  Outer o;
  o.dt = 0.1 + 0.2;  // not representable in few digits
  o.steps = 99;
  o.enabled = false;
  o.colour = Colour::Red;
  o.offset = Eigen::Vector3d(1.0 / 3.0, -0.0, 1e-300);
  o.weights = {};
  o.names = {"left front", "b, c", "d: 'e'"};
  o.inner.gain = 9.999999999999998;
  o.inner.count = 5;
  const std::string text = outerTable().write(o);
  const Outer back = read(text);
  EXPECT_TRUE(same(back, o)) << text;
  EXPECT_EQ(outerTable().write(back), text);
  EXPECT_TRUE(std::signbit(back.offset[1]));
  // Every key is written, sections nested by two spaces.
  EXPECT_NE(text.find("\ninner:\n  gain: 9.999999999999998\n  count: 5\n"), std::string::npos)
      << text;
}

TEST(SettingsTable, DocumentedDefaultsAreTheDefaultConstructedStruct) {
  const std::string doc = outerTable().documented();
  EXPECT_NE(doc.find("dt: 0.01  # [s] (0, 1]\n"), std::string::npos) << doc;
  EXPECT_NE(doc.find("colour: green\n"), std::string::npos) << doc;
  EXPECT_NE(doc.find("  gain: 2.5  # [N/m] [0, 10]\n"), std::string::npos) << doc;
  // The documented text reads back as the defaults.
  EXPECT_TRUE(same(read(doc), Outer{}));
}

TEST(SettingsTable, CheckFindsTheFirstValueOutsideItsRange) {
  Outer o;
  EXPECT_FALSE(outerTable().check(o));
  o.inner.count = 9;
  auto p = outerTable().check(o);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->path, "inner.count");
  EXPECT_EQ(p->what, "9 is outside [1, 5]");
  o = Outer{};
  o.offset[2] = std::numeric_limits<double>::infinity();
  p = outerTable().check(o);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->path, "offset");
  EXPECT_EQ(p->what, "entry 2, inf is outside [-1, 1]");
  o = Outer{};
  o.colour = static_cast<Colour>(7);
  p = outerTable().check(o);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->what, "not red, green or blue");
}

TEST(EnumNames, NamesAndValuesBothWays) {
  EXPECT_STREQ(enumName(Colour::Blue), "blue");
  EXPECT_STREQ(enumName(static_cast<Colour>(9)), "unknown");
  EXPECT_EQ(enumFromName<Colour>("green"), Colour::Green);
  EXPECT_FALSE(enumFromName<Colour>("Green"));
  EXPECT_EQ(enumChoices<Colour>(), "red, green or blue");
}

TEST(SettingsTable, ATableRefusesAKeyTwice) {
  EXPECT_THROW(settings::Table<Inner>().field("gain", &Inner::gain).field("gain", &Inner::gain),
               std::logic_error);
}

}  // namespace rollstep::test_settings
