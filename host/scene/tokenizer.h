// Tokenizer for pbrt-v4 scene text: strings, numbers, brackets and bare words, with locations.
#pragma once
#include <cstddef>
#include <optional>
#include <string>

#include "scene/scene.h"

namespace basalt {

/// One token of a scene file. Comments and white space are dropped.
struct Token {
  enum class Kind { String, Number, Word, LBracket, RBracket } kind = Kind::Word;
  std::string text;   // string contents (escapes decoded, no quotes), or the raw token text
  double number = 0;  // Kind::Number only
  SourceLoc loc;      // 1-based line and column of the token's first character

  bool is_word(const char* w) const { return kind == Kind::Word && text == w; }
  /// \brief True for a number token written as an integer literal (digits with an optional sign).
  bool is_integer_literal() const;
  /// \brief How the token reads in a message: strings quoted, others as written.
  std::string describe() const;
};

/// \brief Splits scene text into tokens (pbrt-v4 parser.cpp Tokenizer::Next, written anew).
/// Numbers are validated when read: a bare word starting with a digit, sign or '.' must be a
/// complete decimal number, so "1.2.3", "1e" and "-" are errors at their location.
class Tokenizer {
 public:
  /// \param text the whole file; \param file the name used in locations.
  Tokenizer(std::string text, std::string file);

  /// \brief The next token, or nothing at the end of the text.
  /// \throws SceneError for an unterminated string or a malformed number.
  std::optional<Token> next();
  /// \brief The next token without consuming it.
  const std::optional<Token>& peek();
  /// \brief Location just past the last character (for end-of-file messages).
  SourceLoc end_loc() const;
  const std::string& file() const { return file_; }

 private:
  std::optional<Token> scan();
  int get();

  std::string text_;
  std::string file_;
  std::size_t pos_ = 0;
  int line_ = 1, column_ = 1;
  bool peeked_ = false;
  std::optional<Token> peek_;
};

}  // namespace basalt
