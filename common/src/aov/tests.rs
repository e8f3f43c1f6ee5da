use super::*;

#[test]
fn a_set_holds_its_passes_in_one_order_whatever_the_list_order() {
    let set = AovSet::of(&[Aov::Id, Aov::Depth, Aov::Albedo]);
    assert_eq!(
        set.iter().collect::<Vec<_>>(),
        [Aov::Depth, Aov::Albedo, Aov::Id]
    );
    assert_eq!(set.values_per_pixel(), 1 + 3 + 1);
    assert!(!set.contains(Aov::Normal));
    assert_eq!(
        set.exr_channels().map(|(_, n)| n).collect::<Vec<_>>(),
        ["Z", "albedo.R", "albedo.G", "albedo.B", "id.id"]
    );
    assert!(AovSet::NONE.is_empty());
    assert_eq!(AovSet::NONE.values_per_pixel(), 0);
    let all = AovSet::of(&Aov::ALL);
    assert_eq!(all.values_per_pixel(), MAX_VALUES_PER_PIXEL);
}

#[test]
fn depth_normal_and_albedo_are_means_over_all_samples_and_the_id_is_sample_zeros() {
    let mut sums = AovSums::default();
    let glass = FirstHit {
        depth: 3.0,
        normal: [0.0, 0.0, 1.0],
        albedo: [1.0, 1.0, 1.0],
        id: 2,
    };
    let floor = FirstHit {
        depth: 5.0,
        normal: [0.0, 1.0, 0.0],
        albedo: [0.5, 0.25, 0.125],
        id: 1,
    };
    sums.add(0, &glass);
    sums.add(1, &floor);
    sums.add(2, &floor);
    sums.add(3, &FirstHit::default()); // the background
    let mut out = Vec::new();
    sums.write_means(AovSet::of(&Aov::ALL), 4, &mut out);
    assert_eq!(
        out,
        [
            13.0 / 4.0,
            0.0,
            0.5,
            0.25,
            0.5,
            0.375,
            0.3125,
            2.0 // sample 0's object, never a blend
        ]
    );
}
