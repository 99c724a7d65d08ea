#include "app/petsc_errors.hpp"

#include <cctype>
#include <sstream>

namespace hyperqn {

PetscErrors::PetscErrors() { PetscPushErrorHandler(record, this); }

PetscErrors::~PetscErrors() { PetscPopErrorHandler(); }

PetscErrorCode PetscErrors::record(MPI_Comm, int, const char* function, const char*, PetscErrorCode n,
                                   PetscErrorType type, const char* message, void* ctx) {
  auto* self = static_cast<PetscErrors*>(ctx);
  if (type == PETSC_ERROR_INITIAL && self->message_.empty()) {  // the cause, not the calls it went through
    self->message_ = message ? message : "";
    self->function_ = function ? function : "";
  }
  return n;
}

std::string PetscErrors::describe() const { return describe(Deck()); }

std::string PetscErrors::describe(const Deck& deck) const {
  if (message_.empty()) return "a PETSc error on another rank";
  std::string text = "PETSc: " + message_ + " (in " + function_ + ")";
  // The option whose value the message quotes: "-name value" pairs of the options database.
  char* all = nullptr;
  if (PetscOptionsGetAll(nullptr, &all) || !all) return text;
  std::istringstream words(all);
  PetscFree(all);
  // Quoted as a whole word ("2.5", not the "5" in it): a value the message holds whole; of several,
  // the longest.
  const auto quoted_whole = [&](const std::string& value) {
    const auto part_of_word = [](char c) { return std::isalnum((unsigned char)c) || c == '.' || c == '-' || c == '+' || c == '_'; };
    for (size_t at = message_.find(value); at != std::string::npos; at = message_.find(value, at + 1))
      if ((at == 0 || !part_of_word(message_[at - 1])) &&
          (at + value.size() == message_.size() || !part_of_word(message_[at + value.size()])))
        return true;
    return false;
  };
  std::string word, name, best_name, best_value;
  while (words >> word) {
    PetscBool key = PETSC_FALSE;  // PETSc's own rule: "-inf" and "-1e5" are values, "-info" a name
    PetscOptionsValidKey(word.c_str(), &key);
    if (key)
      name = word;
    else if (!name.empty() && word.size() > best_value.size() && quoted_whole(word)) {
      best_name = name;
      best_value = word;
    }
  }
  if (!best_name.empty()) {
    // From the deck only if the deck gave this value (the command line wins over the deck).
    const Deck::OptionPlace* place = deck_option_place(deck, best_name, best_value);
    const std::string where = place ? deck.path + ":" + std::to_string(place->line) + ", petsc: section" : "command line";
    return "option " + best_name + " " + best_value + " (" + where + "): " + text;
  }
  return text;
}

}  // namespace hyperqn
