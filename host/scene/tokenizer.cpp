// Tokenizer for pbrt-v4 scene text (pbrt-v4 src/pbrt/parser.cpp Tokenizer, re-implemented).
#include "scene/tokenizer.h"

#include <charconv>
#include <cmath>

namespace basalt {

namespace {

// True for the characters that end a bare word (pbrt-v4: space, quote, bracket; '#' added so
// that a comment may follow a number without a space).
bool ends_word(int ch) {
  return ch == ' ' || ch == '\t' || ch == '\n' || ch == '\r' || ch == '"' || ch == '[' ||
         ch == ']' || ch == '#';
}

// Parses a complete decimal number (optional sign, digits, '.', exponent); nothing else.
std::optional<double> parse_number(const std::string& s) {
  for (char c : s)
    if (!((c >= '0' && c <= '9') || c == '.' || c == 'e' || c == 'E' || c == '+' || c == '-'))
      return std::nullopt;  // also rejects "inf", "nan" and hex, which from_chars would take
  const char* first = s.data();
  const char* last = s.data() + s.size();
  if (first != last && *first == '+') ++first;  // from_chars does not take a leading '+'
  if (first != last && *first == '+') return std::nullopt;
  double v = 0;
  auto [ptr, ec] = std::from_chars(first, last, v, std::chars_format::general);
  if (ec != std::errc() || ptr != last || !std::isfinite(v)) return std::nullopt;
  return v;
}

}  // namespace

bool Token::is_integer_literal() const {
  if (kind != Kind::Number || text.empty()) return false;
  std::size_t i = (text[0] == '+' || text[0] == '-') ? 1 : 0;
  if (i == text.size()) return false;
  for (; i < text.size(); ++i)
    if (text[i] < '0' || text[i] > '9') return false;
  return true;
}

std::string Token::describe() const {
  if (kind == Kind::String) return "\"" + text + "\"";
  return text;
}

Tokenizer::Tokenizer(std::string text, std::string file)
    : text_(std::move(text)), file_(std::move(file)) {
  // pbrt-v4 refuses UTF-16 (Tokenizer::CheckUTF); a UTF-8 byte-order mark is skipped.
  auto byte = [this](std::size_t i) { return (unsigned char)text_[i]; };
  if (text_.size() >= 2 &&
      ((byte(0) == 0xfe && byte(1) == 0xff) || (byte(0) == 0xff && byte(1) == 0xfe)))
    throw SceneError(SourceLoc{file_, 1, 1}, "file is UTF-16 encoded; only UTF-8 is supported");
  if (text_.size() >= 3 && byte(0) == 0xef && byte(1) == 0xbb && byte(2) == 0xbf) pos_ = 3;
}

// Reads one character, advancing the line and column; -1 at the end.
int Tokenizer::get() {
  if (pos_ >= text_.size()) return -1;
  unsigned char ch = text_[pos_++];
  if (ch == '\n') {
    ++line_;
    column_ = 1;
  } else {
    ++column_;
  }
  return ch;
}

SourceLoc Tokenizer::end_loc() const { return SourceLoc{file_, line_, column_}; }

std::optional<Token> Tokenizer::next() {
  if (peeked_) {
    peeked_ = false;
    return std::move(peek_);
  }
  return scan();
}

const std::optional<Token>& Tokenizer::peek() {
  if (!peeked_) {
    peek_ = scan();
    peeked_ = true;
  }
  return peek_;
}

// Scans the next token from the text (comments and white space skipped).
std::optional<Token> Tokenizer::scan() {
  while (true) {
    SourceLoc loc{file_, line_, column_};
    std::size_t start = pos_;
    int ch = get();
    if (ch < 0) return std::nullopt;
    if (ch == ' ' || ch == '\t' || ch == '\n' || ch == '\r') continue;
    if (ch == '#') {  // comment to the end of the line
      while (pos_ < text_.size() && text_[pos_] != '\n' && text_[pos_] != '\r') get();
      continue;
    }
    Token t;
    t.loc = loc;
    if (ch == '[' || ch == ']') {
      t.kind = ch == '[' ? Token::Kind::LBracket : Token::Kind::RBracket;
      t.text = std::string(1, char(ch));
      return t;
    }
    if (ch == '"') {
      // Quoted string: may not span lines (pbrt-v4: "unterminated string").
      t.kind = Token::Kind::String;
      while (true) {
        ch = get();
        if (ch < 0 || ch == '\n' || ch == '\r') throw SceneError(loc, "unterminated string");
        if (ch == '"') break;
        if (ch == '\\') {
          int e = get();
          switch (e) {
            case 'b':
              t.text += '\b';
              break;
            case 'f':
              t.text += '\f';
              break;
            case 'n':
              t.text += '\n';
              break;
            case 'r':
              t.text += '\r';
              break;
            case 't':
              t.text += '\t';
              break;
            case '\\':
              t.text += '\\';
              break;
            case '\'':
              t.text += '\'';
              break;
            case '"':
              t.text += '"';
              break;
            case -1:
            case '\n':
              throw SceneError(loc, "unterminated string");
            default:
              throw SceneError(
                  loc, std::string("unknown escape sequence '\\") + char(e) + "' in string");
          }
          continue;
        }
        t.text += char(ch);
      }
      return t;
    }
    // Bare word or number: runs to white space, a quote, a bracket or a comment.
    while (pos_ < text_.size() && !ends_word((unsigned char)text_[pos_])) get();
    t.text = text_.substr(start, pos_ - start);
    char c0 = t.text[0];
    if ((c0 >= '0' && c0 <= '9') || c0 == '-' || c0 == '+' || c0 == '.') {
      std::optional<double> v = parse_number(t.text);
      if (!v) throw SceneError(loc, "malformed number '" + t.text + "'");
      t.kind = Token::Kind::Number;
      t.number = *v;
    } else {
      t.kind = Token::Kind::Word;
    }
    return t;
  }
}

}  // namespace basalt
