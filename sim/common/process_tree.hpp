// What is left of a process's tree: its children as /proc lists them (the kernel lists a
// process's children nowhere else on every configuration; /proc/PID/task/TID/children needs
// CONFIG_PROC_CHILDREN). Used by a subreaper (PR_SET_CHILD_SUBREAPER), to which every orphan of
// its tree is reparented, to end all of it.
#pragma once

#include <sys/types.h>

#include <span>

namespace locsim {

/// This process's children (living or ended, not yet reaped) except those in `spare`, as many as
/// `out` holds; returns how many it wrote. System calls only, no allocation: safe in the child of
/// a fork of a process with threads.
std::size_t list_children(std::span<pid_t> out, std::span<const pid_t> spare = {});

/// As a subreaper: kills every child except `spare` (SIGKILL), reaps them, and again (their
/// children come here as they die) until no child but `spare` is left. Blocks until then (a
/// process in uninterruptible sleep is waited for). Same safety as list_children.
void end_children(std::span<const pid_t> spare = {});

}  // namespace locsim
