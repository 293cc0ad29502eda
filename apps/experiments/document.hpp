#pragma once
// The report's content once, written as Markdown and as HTML: headings, paragraphs,
// tables, images, videos and verbatim text.
#include <string>
#include <vector>

namespace rollstep::experiments {

/// Text read from files (a trial's failure, a folder's name) made safe where it is rendered,
/// in Markdown and in HTML alike: control characters (newlines) become spaces, and text that
/// holds markup characters (| * _ [ ] < > & # \ `) becomes a code span, shown as it is.
std::string literalText(const std::string& text);

class Document {
 public:
  void heading(int level, const std::string& text);
  /// Plain text; `code` spans may be given between backquotes.
  void paragraph(const std::string& text);
  void bullets(const std::vector<std::string>& items);
  void table(const std::vector<std::string>& header,
             const std::vector<std::vector<std::string>>& rows);
  void image(const std::string& file, const std::string& caption);
  void video(const std::string& file, const std::string& caption);
  void code(const std::string& text);

  std::string markdown() const;
  /// A self-contained page (inline style; pictures and videos are the files beside it).
  std::string html(const std::string& title) const;

 private:
  struct Block {
    enum Kind { Heading, Paragraph, Bullets, Table, Image, Video, Code } kind;
    int level = 0;
    std::string text, file;
    std::vector<std::string> items;
    std::vector<std::vector<std::string>> rows;
  };
  std::vector<Block> blocks_;
};

}  // namespace rollstep::experiments
