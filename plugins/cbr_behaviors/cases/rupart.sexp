; RUPART's initial case memory (004): hand-made behavior cases, plan cases, meta-plans and
; adaptation strategies, for the office floor of cbr_world2d.generate.office (default
; arguments: rooms room_1 .. room_8, hallway ends hall_west and hall_east).
;
; Sonar clauses list the 16 ranges in metres in the Pioneer ring order (front ring 90 50 30 10
; -10 -30 -50 -90 degrees, rear ring -90 -130 -150 -170 170 150 130 90); one number stands for
; all 16. A range of 5.0 is no echo. In a hallway 2 m wide the side beams read 1 m, the beams
; 50 degrees off the axis 1.3 m, 30 degrees off 2 m and those along it nothing.
; Behavior parameters are centimetres, cm/s and deg/s, or the named levels.
;
; cases/rupart.yaml is this file exported as a case base (cbr_behaviors.casefiles.export).

; --- behavior cases ---------------------------------------------------------------------------

; 004 Figure 4 (a): an open area with few obstacles; moderately fast, turning away from
; obstacles 1.5 m off, avoiding collisions half a metre off
(behavior-case open-area
  (plan-index (sonar 4.0) (map) (behaviors avoidCollision goToPos))
  (((goStraight mod-fast curr-head) med)
   ((avoidObstacle 150 moderate) med)
   ((goToPos curr-goal mod-fast 100) high)
   ((avoidCollision 50 mod-fast) high)))

; 004 Figure 4 (b): a hallway with many obstacles, most likely pedestrians; slow, slowing
; further as they come near so that they step aside
(behavior-case crowded-hallway
  (plan-index
    (sonar 1.0 1.3 1.4 1.2 1.2 1.4 1.3 1.0 1.0 1.3 2.0 5.0 5.0 2.0 1.3 1.0)
    (map landmark object))
  (((followWall curr-head) med)
   ((moveForward slow) med)
   ((slowAvoid 50 very-slow) med-high)
   ((avoidCollision 20 fast) high)
   ((goToPos curr-goal slow 100) med)))

; an empty hallway: along it at cruising speed
(behavior-case empty-hallway
  (plan-index (sonar 1.0 1.3 2.0 5.0 5.0 2.0 1.3 1.0 1.0 1.3 2.0 5.0 5.0 2.0 1.3 1.0)
              (map landmark))
  (((goToPos curr-goal fast 30) high)
   ((avoidCollision 40 mod-fast) high)))

; urgent, in the open: fast, with room to turn away early
(behavior-case urgent-open-area
  (plan-index (sonar 4.0) (map) (task-urgency 1.0) (goal-urgency 1.0))
  (((goToPos curr-goal fast 30) high)
   ((avoidObstacle 120 mod-fast) med)
   ((avoidCollision 50 fast) high)))

; a wall close on the left, open to the right: keep along the wall
(behavior-case along-a-wall
  (plan-index (sonar 0.6 0.8 1.2 3.5 5.0 5.0 5.0 5.0 5.0 5.0 5.0 3.5 3.5 1.2 0.8 0.6))
  (((followWall curr-head) med)
   ((goToPos curr-goal mod-fast 30) high)
   ((avoidCollision 40 moderate) high)))

; at a doorway (one within reach on the map): the route passes it square, so head for the
; waypoints slowly and let the jambs come close; avoiding them early would turn the robot
; away from the gap
(behavior-case doorway
  (plan-index (sonar 5.0 1.6 1.2 5.0 5.0 1.2 1.6 5.0 5.0 1.6 1.2 1.0 1.0 1.2 1.6 5.0)
              (map landmark door))
  (((goToPos curr-goal moderate 10) high)
   ((avoidCollision 15 moderate) med)))

; a passage barely wider than the robot: straight on, slowly, collisions avoided late
(behavior-case narrow-passage
  (plan-index (sonar 0.5 0.7 1.0 5.0 5.0 1.0 0.7 0.5 0.5 0.7 1.0 5.0 5.0 1.0 0.7 0.5))
  (((goStraight moderate curr-head) med)
   ((goToPos curr-goal moderate 30) high)
   ((avoidCollision 15 slow) high)))

; a person (a transient object) coming up ahead: slow right down toward them, the goal
; weighing little, and let them pass
(behavior-case approaching-person
  (plan-index (sonar 1.0 1.3 1.8 1.5 1.5 1.8 1.3 1.0 1.0 1.3 2.0 5.0 5.0 2.0 1.3 1.0)
              (map landmark object))
  (((slowAvoid 150 very-slow) high)
   ((goToPos curr-goal moderate 30) low)
   ((avoidCollision 60 moderate) high)))

; the door ahead is shut (a wall where the way goes on, no progress): stop and wait, doors
; of this building open again (at an impasse the case is not retrieved again, so the robot
; does not wait for ever)
(behavior-case door-shut
  (plan-index (sonar 5.0 0.9 0.6 0.5 0.5 0.6 0.9 5.0 5.0 5.0 5.0 5.0 5.0 5.0 5.0 5.0)
              (map landmark) (behav-conf 0.0))
  (((stop) high)
   ((avoidCollision 40 slow) high)))

; a cluttered room: furniture on all sides
(behavior-case cluttered-room
  (plan-index (sonar 1.0 0.8 1.5 2.0 0.9 1.2 0.7 1.8 1.5 2.0 1.1 0.9 2.5 1.4 1.0 0.8)
              (map object))
  (((goToPos curr-goal moderate 20) high)
   ((avoidObstacle 60 slow) med)
   ((avoidCollision 25 moderate) high)))

; inside an office, walls two metres round: out toward the door at moderate speed
(behavior-case leave-room
  (plan-index (sonar 2.0) (map))
  (((goToPos curr-goal mod-fast 20) high)
   ((avoidCollision 30 moderate) high)))

; near the goal: slow, precise, close obstacles allowed
(behavior-case near-the-goal
  (plan-index (sonar 2.0) (map) (task-urgency 0.9))
  (((goToPos curr-goal moderate 10) high)
   ((avoidCollision 25 slow) high)))

; --- meta-plans: generic fall-backs when no case matches well --------------------------------

; move away: into the open, hopefully somewhere more familiar
(meta-plan move-away
  (plan-index (behav-conf 0.0) (sonar 0.8))
  (((goStraight slow curr-head) med)
   ((avoidObstacle 120 slow) high)
   ((avoidCollision 40 moderate) high)))

; localize here: stand and turn, observing for the localization algorithm
(meta-plan localize-here
  (plan-index (loc-conf 0.1))
  (((localize) high)
   ((avoidCollision 40 moderate) high)))

; turn and look: half a turn on the spot, for the sonar to see the other way
(meta-plan turn-and-look
  (plan-index (motors 0.0 0.0) (behav-conf 0.2))
  (((turnTo curr-head 180) high)
   ((avoidCollision 40 moderate) high)))

; --- plan cases: routes over the office floor's places --------------------------------------

(plan-case west-to-east
  (plan-index (location 0.75 5.0) (task-loc 15.25 5.0) (plan-conf 0.2))
  (route hall_west hall_east))

(plan-case east-to-west
  (plan-index (location 15.25 5.0) (task-loc 0.75 5.0) (plan-conf 0.2))
  (route hall_east hall_west))

(plan-case deliver-west-room
  (plan-index (goal deliver room_1 ?priority) (plan) (plan-conf 0.2))
  (route hall_west room_1))

(plan-case deliver-east-room
  (plan-index (goal deliver room_8 ?priority) (plan) (plan-conf 0.2))
  (route hall_east room_8))

; lost: localize first, then by the west end of the hallway, a place easy to recognise
(plan-case relocalize-west
  (plan-index (loc-conf 0.2) (plan-conf 0.3))
  (route hall_west)
  (localize))

; --- adaptation strategies -------------------------------------------------------------------

; 004: "decreasing the speed in behaviors like moveForward if sonar or map values show objects
; closer to the robot than in the retrieved case", by more the larger the difference
(alter-strategy slow-when-closer
  (adapts behavior) (feature sonar) (sense closer) (min 0.05)
  (change (moveForward goStraight goToPos avoidObstacle slowAvoid) speed -0.8))

(alter-strategy speed-up-when-farther
  (adapts behavior) (feature sonar) (sense farther) (min 0.05)
  (change (moveForward goStraight goToPos) speed 1.0))

; more on the map near the robot (transient objects: people, carts) than in the case: turn
; away from them earlier
(alter-strategy widen-when-crowded
  (adapts behavior) (feature map) (sense closer) (min 0.3)
  (change (avoidObstacle avoidCollision slowAvoid) distance 1.0))

; 004: merge "when the retrieved behavior case has very high distance values on some
; features and very low values on others"
(merge-strategy merge-mismatch (adapts behavior) (high 0.6) (low 0.2))
