#pragma once
// The folder source (`folder:DIR`): pairs appear as files in a folder, written by a camera
// program or copied from another machine.
//
// Names: `<id>_left.png` and `<id>_right.png`; `<id>` is the pair's source_id (any
// characters a file name allows, not empty). Other files, and names starting with a dot
// (temporaries), are ignored.
//
// A file counts when it is complete: closed after writing (inotify IN_CLOSE_WRITE) or
// renamed into the folder (IN_MOVED_TO: write under another name, then rename, is the safe
// way to deliver). Files already in the folder at start-up are taken too, once they have
// not changed for `settle` (a file still being written then gets its close event).
// The folder is watched with inotify, not polled; an inotify queue overflow makes the
// source rescan the folder.
//
// A pair is handed out once both files are complete, in the order pairs completed. A
// half pair (one file) still alone after `half_pair_timeout` is handed out as not
// measurable ("right image <path> did not arrive within 10 s of the left"), so that it
// gets its record and does not wait forever.
//
// Once the station has committed a pair's record (or found it recorded before), both
// files are moved to `DIR/done/` (the left first, then the right; a restart finishes a
// move that a kill interrupted), and `done/` keeps the newest `keep_done` pairs: the
// watched folder and done/ stay bounded; the image archive (--archive) is where images
// are kept by policy.
#include <filesystem>
#include <memory>

#include "flatscan/station/pair_source.h"

namespace flatscan {

// Throws InputError naming the folder when it does not exist or cannot be watched.
std::unique_ptr<PairSource> MakeFolderSource(const std::filesystem::path& dir, const FolderSourceOptions& options = {});

}  // namespace flatscan
