#include "document.hpp"

#include <string_view>

#include "rollstep/common/markup.hpp"

namespace rollstep::experiments {

namespace {

/// HTML of inline text: `code` spans become <code>.
std::string inlineHtml(const std::string& s) {
  std::string out;
  bool in_code = false;
  std::string part;
  for (char c : s) {
    if (c == '`') {
      out += in_code ? "<code>" + escapeMarkup(part) + "</code>" : escapeMarkup(part);
      part.clear();
      in_code = !in_code;
    } else {
      part += c;
    }
  }
  out += in_code ? "`" + escapeMarkup(part) : escapeMarkup(part);
  return out;
}

/// A Markdown table cell: '|' escaped, newlines as spaces.
std::string cellMarkdown(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '|')
      out += "\\|";
    else if (c == '\n')
      out += ' ';
    else
      out += c;
  }
  return out;
}

}  // namespace

std::string literalText(const std::string& text) {
  std::string out;
  bool markup = false;
  for (char c : text) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
    if (std::string_view("|*_[]<>&#\\`~").find(c) != std::string_view::npos) markup = true;
    out += c == '`' ? '\'' : c;
  }
  return markup ? "`" + out + "`" : out;
}

void Document::heading(int level, const std::string& text) {
  blocks_.push_back({Block::Heading, level, text, "", {}, {}});
}
void Document::paragraph(const std::string& text) {
  blocks_.push_back({Block::Paragraph, 0, text, "", {}, {}});
}
void Document::bullets(const std::vector<std::string>& items) {
  blocks_.push_back({Block::Bullets, 0, "", "", items, {}});
}
void Document::table(const std::vector<std::string>& header,
                     const std::vector<std::vector<std::string>>& rows) {
  Block b{Block::Table, 0, "", "", header, rows};
  blocks_.push_back(std::move(b));
}
void Document::image(const std::string& file, const std::string& caption) {
  blocks_.push_back({Block::Image, 0, caption, file, {}, {}});
}
void Document::video(const std::string& file, const std::string& caption) {
  blocks_.push_back({Block::Video, 0, caption, file, {}, {}});
}
void Document::code(const std::string& text) {
  blocks_.push_back({Block::Code, 0, text, "", {}, {}});
}

std::string Document::markdown() const {
  std::string out;
  for (const Block& b : blocks_) {
    switch (b.kind) {
      case Block::Heading:
        out += std::string(static_cast<std::size_t>(b.level), '#') + " " + b.text + "\n\n";
        break;
      case Block::Paragraph:
        out += b.text + "\n\n";
        break;
      case Block::Bullets:
        for (const std::string& i : b.items) out += "- " + i + "\n";
        out += "\n";
        break;
      case Block::Table: {
        out += "|";
        for (const std::string& h : b.items) out += " " + cellMarkdown(h) + " |";
        out += "\n|";
        for (std::size_t i = 0; i < b.items.size(); ++i) out += "---|";
        out += "\n";
        for (const auto& row : b.rows) {
          out += "|";
          for (const std::string& c : row) out += " " + cellMarkdown(c) + " |";
          out += "\n";
        }
        out += "\n";
        break;
      }
      case Block::Image:
        out += "![" + b.text + "](" + b.file + ")\n\n*" + b.text + "*\n\n";
        break;
      case Block::Video:
        out += "Video: [" + b.file + "](" + b.file + ") — " + b.text + "\n\n";
        break;
      case Block::Code:
        out += "```\n" + b.text + (b.text.empty() || b.text.back() == '\n' ? "" : "\n") + "```\n\n";
        break;
    }
  }
  return out;
}

std::string Document::html(const std::string& title) const {
  std::string out =
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>" +
      escapeMarkup(title) +
      "</title>\n<style>\nbody{font-family:sans-serif;max-width:1100px;margin:2em "
      "auto;padding:0 1em;line-height:1.45;color:#222}\ntable{border-collapse:collapse;margin:1em "
      "0}\nth,td{border:1px solid #bbb;padding:4px 8px;text-align:left;vertical-align:top}\nth{"
      "background:#eee}\npre{background:#f6f6f6;padding:0.8em;overflow-x:auto;font-size:"
      "85%}\nimg,video{max-width:100%}\nfigure{margin:1em 0}\nfigcaption{font-style:italic}\n"
      "</style></head><body>\n";
  for (const Block& b : blocks_) {
    switch (b.kind) {
      case Block::Heading: {
        const std::string tag = "h" + std::to_string(b.level);
        out += "<" + tag + ">" + inlineHtml(b.text) + "</" + tag + ">\n";
        break;
      }
      case Block::Paragraph:
        out += "<p>" + inlineHtml(b.text) + "</p>\n";
        break;
      case Block::Bullets:
        out += "<ul>\n";
        for (const std::string& i : b.items) out += "<li>" + inlineHtml(i) + "</li>\n";
        out += "</ul>\n";
        break;
      case Block::Table:
        out += "<table>\n<tr>";
        for (const std::string& h : b.items) out += "<th>" + inlineHtml(h) + "</th>";
        out += "</tr>\n";
        for (const auto& row : b.rows) {
          out += "<tr>";
          for (const std::string& c : row) out += "<td>" + inlineHtml(c) + "</td>";
          out += "</tr>\n";
        }
        out += "</table>\n";
        break;
      case Block::Image:
        out += "<figure><img src=\"" + escapeMarkup(b.file) + "\" alt=\"" + escapeMarkup(b.text) +
               "\"><figcaption>" + inlineHtml(b.text) + "</figcaption></figure>\n";
        break;
      case Block::Video:
        out += "<figure><video controls src=\"" + escapeMarkup(b.file) + "\"></video><figcaption>" +
               inlineHtml(b.text) + " (<a href=\"" + escapeMarkup(b.file) + "\">" +
               escapeMarkup(b.file) + "</a>)</figcaption></figure>\n";
        break;
      case Block::Code:
        out += "<pre>" + escapeMarkup(b.text) + "</pre>\n";
        break;
    }
  }
  out += "</body></html>\n";
  return out;
}

}  // namespace rollstep::experiments
