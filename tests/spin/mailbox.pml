/* mailbox's waiter bit (sync/mailbox.hpp), as the header states it.
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
 *               yields); anything but epoch e or its predecessor in the slot,
 *               e - RING, is an overrun (the header reports it: here an
 *               assertion). If the word holds the predecessor without the
 *               bit, set the bit by compare-exchange from exactly that word
 *               (C4; on failure read again: maybe published); then
 *               FUTEX_WAIT on the predecessor with the bit (C5).
 * A participant publishes stage e, waits for stage e of each dependency, then
 * reads their payloads (the compute of stage e + 1), then publishes e + 1.
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
 *      0 <- 2, 1 <- 3, 2 <- {0, 1}, 3 <- {0, 1}.
 * Macros (spin -D): PARTICIPANTS, STAGES (epochs 1..STAGES), RING (slots per
 * producer), LATE (participant 0 publishes stage 1 only once every consumer
 * of it sleeps in FUTEX_WAIT on that slot), SPURIOUS (how many spurious
 * returns of FUTEX_WAIT a run may have), and the deliberate bugs:
 *   BUG_PLAIN_STORE            publish reads the word, then stores the new
 *                              epoch: a waiter bit set in between is lost with
 *                              its wake-up;
 *   BUG_PAYLOAD_AFTER_PUBLISH  the payload is stored after the word: a
 *                              consumer can read the previous occupant's.
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

/* Each participant depends on one or two producers: FIRST, then SECOND
 * (NONE when it has one); it waits for them in that order. */
#define NONE 255
#if PARTICIPANTS == 2
#define FIRST(consumer) (1 - (consumer))
#define SECOND(consumer) NONE
#define CONSUMERS(producer) 1
#elif PARTICIPANTS == 3
#define FIRST(consumer) ((consumer) <= 1 -> 2 : 0)
#define SECOND(consumer) ((consumer) <= 1 -> NONE : 1)
#define CONSUMERS(producer) ((producer) == 2 -> 2 : 1)
#elif PARTICIPANTS == 4
#define FIRST(consumer) ((consumer) == 0 -> 2 : ((consumer) == 1 -> 3 : 0))
#define SECOND(consumer) ((consumer) <= 1 -> NONE : 1)
#define CONSUMERS(producer) ((producer) <= 1 -> 2 : 1)
#else
#error "PARTICIPANTS must be 2, 3 or 4"
#endif

#define WAITER 1
#define EPOCH(word) ((word) >> 1)
/* The stage a slot held before epoch e: e - RING, or the initial epoch 0. */
#define PREVIOUS(e) ((e) > RING -> (e) - RING : 0)
#define SLOT(producer, epoch) ((producer) * RING + (epoch) % RING)

/* Producer p's slot k is word[p * RING + k], payload[p * RING + k]. */
byte word[PARTICIPANTS * RING];
byte payload[PARTICIPANTS * RING];

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
inline consume(producer) {
  do
  :: atomic {
      seen = word[SLOT(producer, epoch)];                  /* acquire poll */
      printf("participant %d: producer %d's slot %d holds epoch %d (waiter bit %d), wants %d\n",
             _pid, producer, SLOT(producer, epoch), EPOCH(seen), seen & WAITER, epoch);
      /* The header's overrun check: the slot holds the stage wanted or the
       * one before it in the slot, nothing else (a producer a whole ring
       * ahead would have overwritten the stage). */
      assert(EPOCH(seen) == epoch || EPOCH(seen) == PREVIOUS(epoch));
      if
      :: EPOCH(seen) == epoch -> seen = 0; break
      :: else -> skip
      fi
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

#if LATE
/* The late producer: participant 0 publishes stage 1 only once every
 * consumer of it sleeps in FUTEX_WAIT on that slot. */
#define SLEEPS_ON(who, slot) (who < PARTICIPANTS && blocked[who] && waiting_on[who] == slot -> 1 : 0)
#define SLEEPERS_ON(slot) (SLEEPS_ON(0, slot) + SLEEPS_ON(1, slot) + SLEEPS_ON(2, slot) + SLEEPS_ON(3, slot))
#define MAY_PUBLISH (epoch != 1 || _pid != 0 || SLEEPERS_ON(SLOT(0, 1)) == CONSUMERS(0))
#else
#define MAY_PUBLISH true
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

    /* Consume stage `epoch` of every dependency. */
    consume(FIRST(_pid));
    if
    :: SECOND(_pid) != NONE -> consume(SECOND(_pid))
    :: else -> skip
    fi;

    /* Compute stage epoch + 1: read the dependencies' payloads. No stale,
     * overwritten or torn value: each is the epoch waited for. (One step: a
     * violation seen by any of several separate reads is seen by this one
     * placed at that read's moment.) */
    atomic {
      printf("participant %d: reads the payload of stage %d from producer %d: %d\n",
             _pid, epoch, FIRST(_pid), payload[SLOT(FIRST(_pid), epoch)]);
      assert(payload[SLOT(FIRST(_pid), epoch)] == epoch);
      if
      :: SECOND(_pid) != NONE ->
        printf("participant %d: reads the payload of stage %d from producer %d: %d\n",
               _pid, epoch, SECOND(_pid), payload[SLOT(SECOND(_pid), epoch)]);
        assert(payload[SLOT(SECOND(_pid), epoch)] == epoch)
      :: else -> skip
      fi;
      epoch++
    }
  od
}

/* No lost wake-up: every participant completes every stage. */
ltl every_participant_proceeds { <> (finished == PARTICIPANTS) }
