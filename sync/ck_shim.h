/* The C interface through which lockstep calls Concurrency Kit's barriers.
 *
 * ck's headers do not compile as C++ (they rely on C-only constructs), so
 * ck_shim.c is the only file that includes them; C++ sees an opaque handle.
 *
 * Contract: create with one of the kinds below and the number of participants
 * (>= 1); returns NULL if memory runs out. Participant `id` (in
 * [0, participants), one thread each, the same every phase) calls
 * lockstep_ck_barrier_wait(barrier, id) once per phase. Destroy after every
 * participant has returned from its last wait.
 * Progress: ck's barriers are pure spin (ck_pr_stall, the CPU's pause, in a
 * loop): no participant ever yields or sleeps, so when participants outnumber
 * CPUs a phase lasts until the scheduler preempts the spinners (milliseconds).
 * Memory ordering: writes before a wait are visible to every participant
 * after it, per architecture:
 *  - x86-64: holds. ck's flag stores and loads are plain moves, which TSO
 *    keeps in order with the data accesses around them; the shim's fences
 *    (ck_shim.c) compile to nothing but a compiler barrier (free).
 *  - AArch64: holds because of the shim: ck issues no release before an
 *    arrival (nor, in dissemination and tournament, an acquire after the
 *    final spin), so the shim puts a release fence before each wait and an
 *    acquire fence after it. With two participants that is the whole edge;
 *    with more, dissemination and tournament relay a phase through other
 *    participants' flags with no fence in between, which AArch64 still orders
 *    (the relaying store depends on the spin's load by control, and ARMv8 is
 *    other-multi-copy atomic), though the C11 model alone would not promise it.
 *  - elsewhere: as AArch64, to the extent ck's port makes its flag accesses
 *    single-copy atomic. */
#ifndef LOCKSTEP_SYNC_CK_SHIM_H
#define LOCKSTEP_SYNC_CK_SHIM_H

#ifdef __cplusplus
extern "C" {
#endif

enum lockstep_ck_kind {
  LOCKSTEP_CK_CENTRALIZED = 0,
  LOCKSTEP_CK_DISSEMINATION = 1,
  LOCKSTEP_CK_TOURNAMENT = 2,
  LOCKSTEP_CK_MCS = 3,
  LOCKSTEP_CK_COMBINING = 4
};

typedef struct lockstep_ck_barrier lockstep_ck_barrier;

lockstep_ck_barrier* lockstep_ck_barrier_create(enum lockstep_ck_kind kind, unsigned participants);
void lockstep_ck_barrier_wait(lockstep_ck_barrier* barrier, unsigned id);
void lockstep_ck_barrier_destroy(lockstep_ck_barrier* barrier);

#ifdef __cplusplus
}
#endif

#endif
