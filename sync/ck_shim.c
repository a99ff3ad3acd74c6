/* Concurrency Kit's barriers behind an opaque C interface (ck_shim.h).
 *
 * Each participant's ck state lives in its own cache-line-aligned slot, set up
 * here at creation: the ck "subscribe" calls hand out thread ids in call
 * order, so subscribing slot 0, 1, 2, ... from the creating thread makes ck's
 * id equal lockstep's participant id. The creating thread publishes all of it
 * to the participants when it starts their threads. */
#include "sync/ck_shim.h"

#include <ck_barrier.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#define LOCKSTEP_CK_LINE 64

/* One participant's state, whatever the kind; a line (or more) of its own so
 * that one participant's sense flips never invalidate a neighbour's line. */
struct lockstep_ck_slot {
  union {
    ck_barrier_centralized_state_t centralized;
    ck_barrier_dissemination_state_t dissemination;
    ck_barrier_tournament_state_t tournament;
    ck_barrier_mcs_state_t mcs;
    ck_barrier_combining_state_t combining;
  } state;
  ck_barrier_combining_group_t* group; /* combining only: the participant's leaf group */
} __attribute__((aligned(LOCKSTEP_CK_LINE)));

_Static_assert(sizeof(struct lockstep_ck_slot) % LOCKSTEP_CK_LINE == 0,
               "participant slots must not share a cache line");

struct lockstep_ck_barrier {
  enum lockstep_ck_kind kind;
  unsigned participants;
  struct lockstep_ck_slot* slots;
  /* centralized */
  ck_barrier_centralized_t centralized __attribute__((aligned(LOCKSTEP_CK_LINE)));
  /* dissemination: ck indexes the barrier itself by thread id (one
   * ck_barrier_dissemination_t per participant, the first holding the shared
   * fields) and each participant's row of flags holds two parities */
  ck_barrier_dissemination_t* dissemination;
  ck_barrier_dissemination_flag_t** dissemination_flags;
  /* tournament */
  ck_barrier_tournament_t tournament;
  ck_barrier_tournament_round_t** tournament_rounds;
  /* mcs: one node per participant */
  ck_barrier_mcs_t* mcs;
  /* combining: a root and one leaf group per pair of participants */
  ck_barrier_combining_t combining;
  ck_barrier_combining_group_t* combining_root;
  ck_barrier_combining_group_t* combining_groups;
};

static void* aligned_zeroed(size_t count, size_t size) {
  size_t bytes = count * size;
  bytes = (bytes + LOCKSTEP_CK_LINE - 1) / LOCKSTEP_CK_LINE * LOCKSTEP_CK_LINE;
  if (bytes == 0) bytes = LOCKSTEP_CK_LINE;
  void* memory = aligned_alloc(LOCKSTEP_CK_LINE, bytes);
  if (memory != NULL) memset(memory, 0, bytes);
  return memory;
}

void lockstep_ck_barrier_destroy(lockstep_ck_barrier* barrier) {
  if (barrier == NULL) return;
  if (barrier->dissemination_flags != NULL)
    for (unsigned id = 0; id < barrier->participants; ++id) free(barrier->dissemination_flags[id]);
  free(barrier->dissemination_flags);
  if (barrier->tournament_rounds != NULL)
    for (unsigned id = 0; id < barrier->participants; ++id) free(barrier->tournament_rounds[id]);
  free(barrier->tournament_rounds);
  free(barrier->dissemination);
  free(barrier->mcs);
  free(barrier->combining_root);
  free(barrier->combining_groups);
  free(barrier->slots);
  free(barrier);
}

lockstep_ck_barrier* lockstep_ck_barrier_create(enum lockstep_ck_kind kind, unsigned participants) {
  if (participants == 0) return NULL;
  lockstep_ck_barrier* barrier = aligned_zeroed(1, sizeof(*barrier));
  if (barrier == NULL) return NULL;
  barrier->kind = kind;
  barrier->participants = participants;
  barrier->slots = aligned_zeroed(participants, sizeof(struct lockstep_ck_slot));
  if (barrier->slots == NULL) goto fail;

  switch (kind) {
    case LOCKSTEP_CK_CENTRALIZED: {
      const ck_barrier_centralized_t initial = CK_BARRIER_CENTRALIZED_INITIALIZER;
      const ck_barrier_centralized_state_t initial_state = CK_BARRIER_CENTRALIZED_STATE_INITIALIZER;
      barrier->centralized = initial;
      for (unsigned id = 0; id < participants; ++id) barrier->slots[id].state.centralized = initial_state;
      break;
    }
    case LOCKSTEP_CK_DISSEMINATION: {
      /* flags[i] is participant i's row of ck_barrier_dissemination_size(n)
       * flags (ck's regression test allocates the same shape). */
      const unsigned size = ck_barrier_dissemination_size(participants);
      barrier->dissemination_flags = calloc(participants, sizeof(*barrier->dissemination_flags));
      if (barrier->dissemination_flags == NULL) goto fail;
      for (unsigned id = 0; id < participants; ++id) {
        barrier->dissemination_flags[id] = aligned_zeroed(size, sizeof(ck_barrier_dissemination_flag_t));
        if (barrier->dissemination_flags[id] == NULL) goto fail;
      }
      barrier->dissemination = aligned_zeroed(participants, sizeof(ck_barrier_dissemination_t));
      if (barrier->dissemination == NULL) goto fail;
      ck_barrier_dissemination_init(barrier->dissemination, barrier->dissemination_flags, participants);
      for (unsigned id = 0; id < participants; ++id)
        ck_barrier_dissemination_subscribe(barrier->dissemination, &barrier->slots[id].state.dissemination);
      break;
    }
    case LOCKSTEP_CK_TOURNAMENT: {
      const unsigned size = ck_barrier_tournament_size(participants);
      barrier->tournament_rounds = calloc(participants, sizeof(*barrier->tournament_rounds));
      if (barrier->tournament_rounds == NULL) goto fail;
      for (unsigned id = 0; id < participants; ++id) {
        barrier->tournament_rounds[id] = aligned_zeroed(size, sizeof(ck_barrier_tournament_round_t));
        if (barrier->tournament_rounds[id] == NULL) goto fail;
      }
      ck_barrier_tournament_init(&barrier->tournament, barrier->tournament_rounds, participants);
      for (unsigned id = 0; id < participants; ++id)
        ck_barrier_tournament_subscribe(&barrier->tournament, &barrier->slots[id].state.tournament);
      break;
    }
    case LOCKSTEP_CK_MCS: {
      barrier->mcs = aligned_zeroed(participants, sizeof(ck_barrier_mcs_t));
      if (barrier->mcs == NULL) goto fail;
      ck_barrier_mcs_init(barrier->mcs, participants);
      for (unsigned id = 0; id < participants; ++id)
        ck_barrier_mcs_subscribe(barrier->mcs, &barrier->slots[id].state.mcs);
      break;
    }
    case LOCKSTEP_CK_COMBINING: {
      /* Leaf groups of two participants (the last may hold one) under one
       * root: a combining tree, rather than one flat group that would make it
       * a centralized barrier with extra steps. */
      const unsigned groups = (participants + 1) / 2;
      barrier->combining_root = aligned_zeroed(1, sizeof(ck_barrier_combining_group_t));
      barrier->combining_groups = aligned_zeroed(groups, sizeof(ck_barrier_combining_group_t));
      if (barrier->combining_root == NULL || barrier->combining_groups == NULL) goto fail;
      ck_barrier_combining_init(&barrier->combining, barrier->combining_root);
      for (unsigned group = 0; group < groups; ++group) {
        const unsigned members = (2 * group + 1 < participants) ? 2u : 1u;
        ck_barrier_combining_group_init(&barrier->combining, &barrier->combining_groups[group], members);
      }
      const ck_barrier_combining_state_t initial_state = CK_BARRIER_COMBINING_STATE_INITIALIZER;
      for (unsigned id = 0; id < participants; ++id) {
        barrier->slots[id].state.combining = initial_state;
        barrier->slots[id].group = &barrier->combining_groups[id / 2];
      }
      break;
    }
    default:
      goto fail;
  }
  return barrier;

fail:
  lockstep_ck_barrier_destroy(barrier);
  return NULL;
}

/* ck's barriers issue no release before a participant's arrival (the
 * dissemination flag, the tournament opponent's flag, the MCS parent's flag,
 * the centralized and combining counters' fetch-and-add) and the
 * dissemination and tournament barriers no acquire after the spin that ends a
 * phase. On x86-64 (TSO) stores are not reordered with earlier accesses, nor
 * loads with later ones, so ck is right without fences there; on AArch64 a
 * data write before the wait could become visible after the arrival flag,
 * and a read after the wait could be satisfied before the flag was seen. The
 * shim adds both fences (ck_shim.h states the promise per architecture). */
void lockstep_ck_barrier_wait(lockstep_ck_barrier* barrier, unsigned id) {
  struct lockstep_ck_slot* slot = &barrier->slots[id];
#if !defined(__SANITIZE_THREAD__) /* TSan does not model fences (GCC warns); ck is left out of TSan anyway */
  /* (1) release: the caller's writes before ck's arrival store or RMW; pairs
   * with (2) in every participant that sees that arrival (directly, or
   * through the flags other participants set after seeing it). x86-64: a
   * compiler barrier, no instruction. AArch64: dmb ish. */
  atomic_thread_fence(memory_order_release);
#endif
  switch (barrier->kind) {
    case LOCKSTEP_CK_CENTRALIZED:
      ck_barrier_centralized(&barrier->centralized, &slot->state.centralized, barrier->participants);
      break;
    case LOCKSTEP_CK_DISSEMINATION:
      ck_barrier_dissemination(barrier->dissemination, &slot->state.dissemination);
      break;
    case LOCKSTEP_CK_TOURNAMENT:
      ck_barrier_tournament(&barrier->tournament, &slot->state.tournament);
      break;
    case LOCKSTEP_CK_MCS:
      ck_barrier_mcs(barrier->mcs, &slot->state.mcs);
      break;
    case LOCKSTEP_CK_COMBINING:
      ck_barrier_combining(&barrier->combining, slot->group, &slot->state.combining);
      break;
  }
#if !defined(__SANITIZE_THREAD__)
  /* (2) acquire: pairs with (1): the caller's reads after the wait see what
   * every participant wrote before its wait. x86-64: a compiler barrier, no
   * instruction. AArch64: dmb ishld. */
  atomic_thread_fence(memory_order_acquire);
#endif
}
