#include "document.hpp"

#include <cmark-gfm-core-extensions.h>
#include <cmark-gfm.h>

#include <cstdlib>
#include <stdexcept>
#include <string_view>

#include "rollstep/common/markup.hpp"

namespace rollstep::experiments {

namespace {

/// Markdown of text: '<' outside `code` spans escaped (text such as "<scenario>" is not an
/// HTML tag; the report's raw HTML is only its video players).
std::string textMarkdown(const std::string& s) {
  std::string out;
  bool in_code = false;
  for (char c : s) {
    if (c == '`') in_code = !in_code;
    if (c == '<' && !in_code) out += '\\';
    out += c;
  }
  return out;
}

/// A Markdown table cell: '|' escaped, newlines as spaces.
std::string cellMarkdown(const std::string& text) {
  const std::string s = textMarkdown(text);
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

/// GitHub Flavored Markdown to HTML by cmark-gfm (its table extension). Raw HTML (the
/// videos' elements) is kept: the document is ours, not user input.
std::string gfmToHtml(const std::string& markdown) {
  cmark_gfm_core_extensions_ensure_registered();
  const int options = CMARK_OPT_UNSAFE;
  cmark_parser* parser = cmark_parser_new(options);
  if (parser == nullptr) throw std::runtime_error("cmark-gfm: no parser");
  if (cmark_syntax_extension* table = cmark_find_syntax_extension("table"); table != nullptr) {
    cmark_parser_attach_syntax_extension(parser, table);
  }
  cmark_parser_feed(parser, markdown.data(), markdown.size());
  cmark_node* root = cmark_parser_finish(parser);
  char* html = cmark_render_html(root, options, cmark_parser_get_syntax_extensions(parser));
  std::string out = html != nullptr ? html : "";
  std::free(html);
  cmark_node_free(root);
  cmark_parser_free(parser);
  if (html == nullptr) throw std::runtime_error("cmark-gfm: rendering failed");
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
        out += std::string(static_cast<std::size_t>(b.level), '#') + " " + textMarkdown(b.text) +
               "\n\n";
        break;
      case Block::Paragraph:
        out += textMarkdown(b.text) + "\n\n";
        break;
      case Block::Bullets:
        for (const std::string& i : b.items) out += "- " + textMarkdown(i) + "\n";
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
        // The player as raw HTML (GFM keeps it), then the link for viewers that drop it.
        out += "<video controls src=\"" + escapeMarkup(b.file) + "\"></video>\n\n";
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
  return "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>" +
         escapeMarkup(title) +
         "</title>\n<style>\nbody{font-family:sans-serif;max-width:1100px;margin:2em "
         "auto;padding:0 1em;line-height:1.45;color:#222}\ntable{border-collapse:collapse;margin:"
         "1em 0}\nth,td{border:1px solid #bbb;padding:4px 8px;text-align:left;vertical-align:"
         "top}\nth{background:#eee}\npre{background:#f6f6f6;padding:0.8em;overflow-x:auto;font-"
         "size:85%}\nimg,video{max-width:100%}\n</style></head><body>\n" +
         gfmToHtml(markdown()) + "</body></html>\n";
}

}  // namespace rollstep::experiments
