use std::time::Instant;

use super::*;

/// Work that runs until interrupted (checking every millisecond), for at most `most`.
fn until_interrupted(most: Duration) -> impl FnOnce(&Interrupt) -> bool + Send + 'static {
    move |interrupt| {
        let started = Instant::now();
        while !interrupt.is_set() && started.elapsed() < most {
            std::thread::sleep(Duration::from_millis(1));
        }
        interrupt.is_set()
    }
}

#[tokio::test]
async fn work_past_its_limit_is_walked_away_from_and_told_to_stop() {
    let gate = Gate::new();
    let slot = gate.slot().await;
    let started = Instant::now();
    let ended = run(
        &slot,
        "test",
        Duration::from_millis(100),
        &CancellationToken::new(),
        until_interrupted(Duration::from_secs(30)),
    )
    .await;
    let waited = started.elapsed();
    assert!(matches!(ended, Ended::OverLimit), "{ended:?}");
    assert!(
        waited >= Duration::from_millis(100) && waited < Duration::from_secs(2),
        "{waited:?}"
    );
    // The thread sees its interrupt and lets its slot go.
    drop(slot);
    let free = tokio::time::timeout(Duration::from_secs(5), async {
        while gate.free() < SLOTS {
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    })
    .await;
    assert!(free.is_ok(), "the interrupted thread kept its slot");
}

#[tokio::test]
async fn a_stop_ends_the_wait_at_once_and_a_result_is_returned_as_it_is() {
    let gate = Gate::new();
    let slot = gate.slot().await;
    let stop = CancellationToken::new();
    let cancel = stop.clone();
    tokio::spawn(async move {
        tokio::time::sleep(Duration::from_millis(50)).await;
        cancel.cancel();
    });
    let started = Instant::now();
    let ended = run(
        &slot,
        "test",
        Duration::from_secs(60),
        &stop,
        until_interrupted(Duration::from_secs(30)),
    )
    .await;
    assert!(matches!(ended, Ended::Stopped), "{ended:?}");
    assert!(started.elapsed() < Duration::from_secs(2));
    let ended = run(
        &slot,
        "test",
        Duration::from_secs(60),
        &CancellationToken::new(),
        |_| 7,
    )
    .await;
    assert!(matches!(ended, Ended::Done(7)), "{ended:?}");
    let ended: Ended<()> = run(
        &slot,
        "test",
        Duration::from_secs(60),
        &CancellationToken::new(),
        |_| panic!("boom"),
    )
    .await;
    assert!(
        matches!(&ended, Ended::Broke(m) if m == "panicked: boom"),
        "{ended:?}"
    );
}

#[tokio::test]
async fn abandoned_work_holds_at_most_one_slot_beyond_the_work_in_hand() {
    let gate = Gate::new();
    // Two pieces of work walked away from, each still running (it ignores its interrupt).
    let release = Arc::new(AtomicBool::new(false));
    for _ in 0..SLOTS {
        let slot = gate.slot().await;
        let release = release.clone();
        let ended = run(
            &slot,
            "test",
            Duration::from_millis(10),
            &CancellationToken::new(),
            move |_| {
                while !release.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(1));
                }
            },
        )
        .await;
        assert!(matches!(ended, Ended::OverLimit), "{ended:?}");
    }
    assert_eq!(gate.free(), 0);
    let waiting = tokio::time::timeout(Duration::from_millis(200), gate.slot()).await;
    assert!(waiting.is_err(), "a third thread was let in");
    release.store(true, Ordering::Relaxed);
    let slot = tokio::time::timeout(Duration::from_secs(5), gate.slot()).await;
    assert!(
        slot.is_ok(),
        "the gate did not open when the abandoned work ended"
    );
}
