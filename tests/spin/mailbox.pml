/* mailbox's waiter bit and acknowledgements (sync/mailbox.hpp), as the
 * header states them.
 *
 * Each producer owns a ring of RING slots (the header's kDepth: 4); slot k
 * holds a word, epoch << 1 | waiter bit, and a payload. Stage e lives in slot
 * e % RING, so the ring is reused every RING stages; a slot starts holding
 * epoch 0 (the header: the word of stage slot - kDepth, its predecessor).
 * Every participant produces one value per stage and consumes the values of
 * the producers it depends on:
 *   publish(e): store the payload, exchange the word to epoch e (waiter bit
 *               clear), FUTEX_WAKE every waiter when the old word had the bit
 *               (the header's (P1), (P2), (P3));
 *   consume(p, e): read producer p's word (the poll (C1)/(C3): one read at a
 *               moment the scheduler picks stands for the spin and the
 *               yields); an epoch, the waiter bit masked (another consumer
 *               a lap ahead may have set it on the wanted word), other than
 *               e or its predecessor in the slot, e - RING, is an overrun
 *               (the header reports it: here an assertion). If the word
 *               holds the predecessor without the bit, set the bit by
 *               compare-exchange from exactly that word (C4; on failure read
 *               again: maybe published); then FUTEX_WAIT on the predecessor
 *               with the bit (C5).
 *   receive(p, e): consume(p, e), read the payload (C2), then, on an
 *               acknowledged edge, store "received up to e" (A1).
 *   acknowledgements: an edge p -> c whose path back c -> ... -> p is longer
 *               than RING - 1 edges (or missing) is acknowledged, as the
 *               header's constructor decides; before p publishes e > RING it
 *               waits until each such consumer received e - RING, the slot's
 *               occupant (A2; the header's wait_for_acknowledgements, which
 *               yields: here a guard).
 * A participant publishes stage e, receives stage e from each dependency in
 * turn (the compute of stage e + 1 reads the payloads), then publishes e + 1.
 * The payload is a ghost: the epoch itself, so a stale or overwritten payload
 * shows as a payload that is not the epoch the consumer waited for.
 * Sequential consistency throughout: see README.md. Each step prints what it
 * does (pan ignores printf; a trail replay shows it).
 *
 * Dependency graphs (PARTICIPANTS):
 *   2: 0 <- 1, 1 <- 0 (two blocks, each reads the other);
 *   3: 0 <- 2, 1 <- 2, 2 <- {0, 1} (one producer with two consumers, one
 *      consumer of two producers);
 *   4: the RK4 step, D1 <- x3, D2 <- x4, D3 and D4 <- x1, x2:
 *      0 <- 2, 1 <- 3, 2 <- {0, 1}, 3 <- {0, 1}; the paths back are one
 *      edge long but for the edges 1 -> 2 (2 -> 0 -> 3 -> 1) and 0 -> 3
 *      (3 -> 1 -> 2 -> 0), three: with RING < 4 those two are acknowledged;
 *   2 with PIPELINE: 1 <- 0 only, no path back: acknowledged at any RING.
 * Macros (spin -D): PARTICIPANTS, STAGES (epochs 1..STAGES), RING (slots per
 * producer), PIPELINE (the graph 1 <- 0), LATE (participant 0 publishes
 * stage 1 only once every consumer of it sleeps in FUTEX_WAIT on that slot),
 * LAP_AHEAD (3 participants, RING 2: consumer 0 polls producer 2's stage 1
 * only once consumer 1, a lap ahead, has set the waiter bit on that word
 * while it waits for stage 3 in the same slot), SPURIOUS (how many spurious returns
 * of FUTEX_WAIT a run may have), and the deliberate bugs:
 *   BUG_PLAIN_STORE            publish reads the word, then stores the new
 *                              epoch: a waiter bit set in between is lost with
 *                              its wake-up;
 *   BUG_PAYLOAD_AFTER_PUBLISH  the payload is stored after the word: a
 *                              consumer can read the previous occupant's;
 *   BUG_WAITER_BIT_UNMASKED    the poll compares the whole word with the
 *                              wanted one, waiter bit included (the header's
 *                              wait_for_stage masks it): a wanted word that
 *                              carries the bit of a consumer a lap ahead is
 *                              taken for an overrun;
 *   BUG_NO_ACKS                no edge is acknowledged (the ring alone);
 *   BUG_ACK_BEFORE_READ        the consumer stores "received" (A1) before it
 *                              reads the payload: the producer may overwrite
 *                              the slot under the read;
 *   BUG_ACK_OFF_BY_ONE         the producer waits for e - RING - 1 instead of
 *                              e - RING (one stage short of the occupant);
 *   BUG_ACK_LOST               the consumer never stores "received": the
 *                              producer waits for good before its first reuse.
 */
#ifndef PARTICIPANTS
#define PARTICIPANTS 4
#endif
#ifndef RING
#define RING 4
#endif
#ifndef STAGES
#define STAGES (RING + 1)
#endif
#ifndef LATE
#define LATE 0
#endif
#ifndef SPURIOUS
#define SPURIOUS 1
#endif
#ifndef BUG_PLAIN_STORE
#define BUG_PLAIN_STORE 0
#endif
#ifndef BUG_PAYLOAD_AFTER_PUBLISH
#define BUG_PAYLOAD_AFTER_PUBLISH 0
#endif
#ifndef BUG_WAITER_BIT_UNMASKED
#define BUG_WAITER_BIT_UNMASKED 0
#endif
#ifndef BUG_NO_ACKS
#define BUG_NO_ACKS 0
#endif
#ifndef BUG_ACK_BEFORE_READ
#define BUG_ACK_BEFORE_READ 0
#endif
#ifndef BUG_ACK_OFF_BY_ONE
#define BUG_ACK_OFF_BY_ONE 0
#endif
#ifndef BUG_ACK_LOST
#define BUG_ACK_LOST 0
#endif
#ifndef PIPELINE
#define PIPELINE 0
#endif
#ifndef LAP_AHEAD
#define LAP_AHEAD 0
#endif
#if LAP_AHEAD && (PARTICIPANTS != 3 || RING != 2 || STAGES < 3)
#error "LAP_AHEAD needs PARTICIPANTS 3 (producer 2's two consumers), RING 2 and STAGES >= 3"
#endif

/* Each participant depends on up to two producers: FIRST, then SECOND (NONE
 * when it has fewer); it receives from them in that order. PATH_BACK(p, c):
 * the length of the shortest path c -> ... -> p along producer -> consumer
 * edges (NO_PATH if none), the header's path_back. */
#define NONE 255
#define NO_PATH 255
#if PARTICIPANTS == 2 && PIPELINE
#define FIRST(consumer) ((consumer) == 1 -> 0 : NONE)
#define SECOND(consumer) NONE
#define CONSUMERS(producer) ((producer) == 0 -> 1 : 0)
#define PATH_BACK(producer, consumer) NO_PATH
#elif PARTICIPANTS == 2
#define FIRST(consumer) (1 - (consumer))
#define SECOND(consumer) NONE
#define CONSUMERS(producer) 1
#define PATH_BACK(producer, consumer) 1
#elif PIPELINE
#error "PIPELINE needs PARTICIPANTS 2"
#elif PARTICIPANTS == 3
#define FIRST(consumer) ((consumer) <= 1 -> 2 : 0)
#define SECOND(consumer) ((consumer) <= 1 -> NONE : 1)
#define CONSUMERS(producer) ((producer) == 2 -> 2 : 1)
#define PATH_BACK(producer, consumer) 1
#elif PARTICIPANTS == 4
#define FIRST(consumer) ((consumer) == 0 -> 2 : ((consumer) == 1 -> 3 : 0))
#define SECOND(consumer) ((consumer) <= 1 -> NONE : 1)
#define CONSUMERS(producer) ((producer) <= 1 -> 2 : 1)
#define PATH_BACK(producer, consumer) \
  (((producer) == 1 && (consumer) == 2) || ((producer) == 0 && (consumer) == 3) -> 3 : 1)
#else
#error "PARTICIPANTS must be 2, 3 or 4"
#endif
#define DEPENDS(consumer, producer) (FIRST(consumer) == (producer) || SECOND(consumer) == (producer))
/* The header's constructor: an edge is acknowledged when the ring alone does
 * not cover it (no path back, or RING < path back + 1). */
#if BUG_NO_ACKS
#define ACKED(producer, consumer) false
#else
#define ACKED(producer, consumer) \
  (PATH_BACK(producer, consumer) == NO_PATH || PATH_BACK(producer, consumer) + 1 > RING)
#endif

#define WAITER 1
#define EPOCH(word) ((word) >> 1)
/* The stage a slot held before epoch e: e - RING, or the initial epoch 0. */
#define PREVIOUS(e) ((e) > RING -> (e) - RING : 0)
#define SLOT(producer, epoch) ((producer) * RING + (epoch) % RING)

/* Producer p's slot k is word[p * RING + k], payload[p * RING + k]. */
byte word[PARTICIPANTS * RING];
byte payload[PARTICIPANTS * RING];

/* received[c * PARTICIPANTS + p]: the last stage consumer c received from
 * producer p (the header's received row, (A1)). Stored on acknowledged edges
 * only: no producer reads it elsewhere. */
byte received[PARTICIPANTS * PARTICIPANTS];

/* The kernel: who sleeps in FUTEX_WAIT, and on which word. */
bool blocked[PARTICIPANTS];
byte waiting_on[PARTICIPANTS];

/* Spurious returns FUTEX_WAIT may still make in this run. */
byte spurious = SPURIOUS;

/* Ghost: participants done (liveness). */
byte finished = 0;

/* Steps: every atomic block below holds one access to the protocol's shared
 * state (a load, a store or a read-modify-write: the interleaving point; ghost
 * variables do not count) and the local bookkeeping around it, so that states
 * are stored only where another participant could act. */

/* FUTEX_WAIT(&word[slot], expected), to be called inside an atomic block:
 * compares and blocks, atomically with respect to FUTEX_WAKE, and returns
 * when woken; returns at once when the word differs (EAGAIN) or, while the
 * spurious budget lasts, without a wake-up (EINTR: returning at once is as
 * general as returning later, since the caller may be delayed before it
 * reads the word again). */
inline futex_wait(slot, expected) {
  if
  :: word[slot] == (expected) ->
    if
    :: spurious > 0 -> spurious--;
      printf("participant %d: FUTEX_WAIT returns at once (EINTR)\n", _pid)
    :: true -> blocked[_pid] = true; waiting_on[_pid] = slot;
      printf("participant %d: FUTEX_WAIT on slot %d: sleeps\n", _pid, slot);
      !blocked[_pid];
      printf("participant %d: woken\n", _pid)
    fi
  :: else -> printf("participant %d: FUTEX_WAIT: the word changed (EAGAIN)\n", _pid)
  fi
}

/* FUTEX_WAKE(&word[slot], INT_MAX), inside an atomic block. */
inline futex_wake(slot) {
  printf("participant %d: FUTEX_WAKE on slot %d\n", _pid, slot);
  index = 0;
  do
  :: index < PARTICIPANTS ->
    if
    :: blocked[index] && waiting_on[index] == slot -> blocked[index] = false; waiting_on[index] = 0
    :: else -> skip
    fi;
    index++
  :: else -> break
  od;
  index = 0
}

/* consume(producer): wait until the producer's slot holds stage `epoch`. */
#if LAP_AHEAD
/* Consumer 0 polls producer 2's stage 1 only once that slot holds stage 1
 * with the waiter bit: consumer 1 has received stages 1 and 2 and waits for
 * stage 3 in the same slot, a lap ahead of consumer 0 (the ring of two
 * allows the skew: the path back from either consumer to producer 2 is one
 * edge). Producer 2 cannot publish stage 3 before consumer 0 received stage
 * 1, so every run reaches that state, or the search reports the deadlock. */
#define MAY_POLL (_pid != 0 || epoch != 1 || word[SLOT(2, 1)] == (1 << 1 | WAITER))
#else
#define MAY_POLL true
#endif

inline consume(producer) {
  do
  :: atomic {
      MAY_POLL;
      seen = word[SLOT(producer, epoch)];                  /* acquire poll */
      printf("participant %d: producer %d's slot %d holds epoch %d (waiter bit %d), wants %d\n",
             _pid, producer, SLOT(producer, epoch), EPOCH(seen), seen & WAITER, epoch);
#if BUG_WAITER_BIT_UNMASKED
      /* The whole word against the wanted one; the bit masked only for the
       * predecessor. */
      assert(seen == epoch << 1 || EPOCH(seen) == PREVIOUS(epoch));
      if
      :: seen == epoch << 1 -> seen = 0; break
      :: else -> skip
      fi
#else
      /* The header's overrun check, on the word without the waiter bit: the
       * slot holds the stage wanted or the one before it in the slot, nothing
       * else (a producer a whole ring ahead would have overwritten the
       * stage). The bit may sit on the wanted word too, set by another
       * consumer a lap ahead. */
      assert(EPOCH(seen) == epoch || EPOCH(seen) == PREVIOUS(epoch));
      if
      :: EPOCH(seen) == epoch -> seen = 0; break
      :: else -> skip
      fi
#endif
    }
    /* Sleep: set the waiter bit on the value read (compare-exchange; if the
     * word changed, read it again), then FUTEX_WAIT on the value with it. */
    if
    :: atomic { seen & WAITER -> futex_wait(SLOT(producer, epoch), seen) }
    :: atomic {
        !(seen & WAITER) && word[SLOT(producer, epoch)] == PREVIOUS(epoch) << 1 ->
        word[SLOT(producer, epoch)] = PREVIOUS(epoch) << 1 | WAITER; seen = PREVIOUS(epoch) << 1 | WAITER;
        printf("participant %d: compare-exchange sets the waiter bit\n", _pid)
      };
      atomic { futex_wait(SLOT(producer, epoch), seen) }
    :: atomic {
        !(seen & WAITER) && word[SLOT(producer, epoch)] != PREVIOUS(epoch) << 1 ->
        printf("participant %d: compare-exchange fails: the word changed\n", _pid)
      }
    fi
  od
}

/* (A1) "received up to stage `epoch`", on an acknowledged edge; inside an
 * atomic block. */
inline acknowledge(producer) {
  if
#if BUG_ACK_LOST
  :: ACKED(producer, _pid) -> printf("participant %d: does not acknowledge stage %d of producer %d\n", _pid, epoch, producer)
#else
  :: ACKED(producer, _pid) -> received[_pid * PARTICIPANTS + producer] = epoch;
    printf("participant %d: acknowledges stage %d of producer %d\n", _pid, epoch, producer)
#endif
  :: else -> skip
  fi
}

/* receive(producer, last): wait for stage `epoch`, read its payload (C2),
 * acknowledge (A1); `last`: the participant's last dependency of the stage,
 * after which it moves on to the next stage.
 * The payload read is one step: a violation seen by any of several separate
 * reads of the values is seen by this one placed at that read's moment. No
 * stale, overwritten or torn value: it is the epoch waited for. The
 * acknowledgement that follows the read shares its step: the only reader of
 * `received` is the producer's guard (A2), which a larger value never
 * disables, so anything that can happen between the two can happen after
 * both. */
inline receive(producer, last) {
  consume(producer);
#if BUG_ACK_BEFORE_READ
  atomic { acknowledge(producer) };
#endif
  atomic {
    printf("participant %d: reads the payload of stage %d from producer %d: %d\n",
           _pid, epoch, producer, payload[SLOT(producer, epoch)]);
    assert(payload[SLOT(producer, epoch)] == epoch);
#if !BUG_ACK_BEFORE_READ
    acknowledge(producer);
#endif
    if
    :: last -> epoch++
    :: else -> skip
    fi
  }
}

/* (A2): every acknowledging consumer c of ours received the slot's occupant,
 * stage e - RING, before we publish e > RING (the header: stage >= kDepth).
 * One guard reads them all: the counters only grow, so reading them one by
 * one, as the code does, succeeds only when this one read at the last of
 * those moments would; and a guard that holds stays true until the publish's
 * first store, so it shares that store's step. */
#if BUG_ACK_OFF_BY_ONE
#define NEEDED(e) ((e) - RING - 1)
#else
#define NEEDED(e) ((e) - RING)
#endif
#define ACK_FROM(c, e) \
  ((c) >= PARTICIPANTS || !DEPENDS(c, _pid) || !ACKED(_pid, c) || received[(c) * PARTICIPANTS + _pid] >= NEEDED(e))
#define ACKNOWLEDGED(e) ((e) <= RING || (ACK_FROM(0, e) && ACK_FROM(1, e) && ACK_FROM(2, e) && ACK_FROM(3, e)))

#if LATE
/* The late producer: participant 0 publishes stage 1 only once every
 * consumer of it sleeps in FUTEX_WAIT on that slot. */
#define SLEEPS_ON(who, slot) (who < PARTICIPANTS && blocked[who] && waiting_on[who] == slot -> 1 : 0)
#define SLEEPERS_ON(slot) (SLEEPS_ON(0, slot) + SLEEPS_ON(1, slot) + SLEEPS_ON(2, slot) + SLEEPS_ON(3, slot))
#define MAY_PUBLISH (ACKNOWLEDGED(epoch) && (epoch != 1 || _pid != 0 || SLEEPERS_ON(SLOT(0, 1)) == CONSUMERS(0)))
#else
#define MAY_PUBLISH ACKNOWLEDGED(epoch)
#endif

#define MINE SLOT(_pid, epoch)
#define STORED printf("participant %d: stage %d: payload stored in slot %d\n", _pid, epoch, MINE)
#define PUBLISHED(waiter) \
  printf("participant %d: stage %d: word of slot %d set to epoch %d (the old one had waiter bit %d)\n", \
         _pid, epoch, MINE, epoch, waiter)

active [PARTICIPANTS] proctype participant() {
  byte epoch = 1;
  byte seen;        /* the word as the consumer read it */
  byte index = 0;

  do
  :: atomic { epoch > STAGES -> finished++; break }
  :: epoch <= STAGES ->
    /* Publish. An exchange that finds the waiter bit is followed by the wake. */
#if BUG_PAYLOAD_AFTER_PUBLISH
    if
    :: atomic { MAY_PUBLISH && (word[MINE] & WAITER) -> word[MINE] = epoch << 1; PUBLISHED(1) };
      atomic { payload[MINE] = epoch; STORED };
      atomic { futex_wake(MINE) }
    :: atomic { MAY_PUBLISH && !(word[MINE] & WAITER) -> word[MINE] = epoch << 1; PUBLISHED(0) };
      atomic { payload[MINE] = epoch; STORED }
    fi;
#elif BUG_PLAIN_STORE
    atomic { MAY_PUBLISH; payload[MINE] = epoch; STORED };
    if
    :: atomic { word[MINE] & WAITER -> printf("participant %d: reads its word: waiter bit 1\n", _pid) };
      atomic { word[MINE] = epoch << 1; PUBLISHED(1) };
      atomic { futex_wake(MINE) }
    :: atomic { !(word[MINE] & WAITER) -> printf("participant %d: reads its word: waiter bit 0\n", _pid) };
      atomic { word[MINE] = epoch << 1; PUBLISHED(0) }
    fi;
#else
    atomic { MAY_PUBLISH; payload[MINE] = epoch; STORED };          /* relaxed payload stores */
    if                                                              /* release exchange */
    :: atomic { word[MINE] & WAITER -> word[MINE] = epoch << 1; PUBLISHED(1) };
      atomic { futex_wake(MINE) }
    :: atomic { !(word[MINE] & WAITER) -> word[MINE] = epoch << 1; PUBLISHED(0) }
    fi;
#endif

    /* Receive stage `epoch` of every dependency, one after the other (the
     * compute of stage epoch + 1). */
    if
#if PIPELINE
    :: FIRST(_pid) == NONE -> epoch++
#endif
    :: FIRST(_pid) != NONE && SECOND(_pid) == NONE -> receive(FIRST(_pid), true)
    :: FIRST(_pid) != NONE && SECOND(_pid) != NONE -> receive(FIRST(_pid), false); receive(SECOND(_pid), true)
    fi
  od
}

/* No lost wake-up: every participant completes every stage. */
ltl every_participant_proceeds { <> (finished == PARTICIPANTS) }
