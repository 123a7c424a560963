/*
 * The link to the host: a USART sending each frame by DMA, 8N1, no flow control.
 * SKIN_BOARD_LINK_USART 1: USART1 (APB2) on PA9/PA10, DMA2 Stream7 channel 4;
 * SKIN_BOARD_LINK_USART 2: USART2 (APB1) on PA2/PA3, DMA1 Stream6 channel 4.
 * Both reach the host as the ST-LINK's virtual COM port (docs/firmware.md, "Link").
 */
#include "nucleo.h"
#include "skin_fw/board.h"
#include "skin_fw/wait.h"

#if SKIN_BOARD_LINK_USART == 1
#define LINK_USART USART1
#define LINK_CLOCK_HZ NUCLEO_APB2_HZ
#define LINK_DMA DMA2
#define LINK_STREAM DMA2_Stream7
#define LINK_DONE (DMA_HISR_TCIF7 | DMA_HISR_TEIF7)
#define LINK_ERROR DMA_HISR_TEIF7
#define LINK_CLEAR (DMA_HIFCR_CTCIF7 | DMA_HIFCR_CHTIF7 | DMA_HIFCR_CTEIF7 | DMA_HIFCR_CDMEIF7 | \
                    DMA_HIFCR_CFEIF7)
#define LINK_CLOCKS_ON()                          \
  do {                                            \
    RCC->APB2ENR |= RCC_APB2ENR_USART1EN;         \
    RCC->AHB1ENR |= RCC_AHB1ENR_DMA2EN;           \
  } while (0)
#define LINK_RESET()                              \
  do {                                            \
    RCC->APB2RSTR |= RCC_APB2RSTR_USART1RST;      \
    RCC->APB2RSTR &= ~RCC_APB2RSTR_USART1RST;     \
  } while (0)
#else
#define LINK_USART USART2
#define LINK_CLOCK_HZ NUCLEO_APB1_HZ
#define LINK_DMA DMA1
#define LINK_STREAM DMA1_Stream6
#define LINK_DONE (DMA_HISR_TCIF6 | DMA_HISR_TEIF6)
#define LINK_ERROR DMA_HISR_TEIF6
#define LINK_CLEAR (DMA_HIFCR_CTCIF6 | DMA_HIFCR_CHTIF6 | DMA_HIFCR_CTEIF6 | DMA_HIFCR_CDMEIF6 | \
                    DMA_HIFCR_CFEIF6)
#define LINK_CLOCKS_ON()                          \
  do {                                            \
    RCC->APB1ENR |= RCC_APB1ENR_USART2EN;         \
    RCC->AHB1ENR |= RCC_AHB1ENR_DMA1EN;           \
  } while (0)
#define LINK_RESET()                              \
  do {                                            \
    RCC->APB1RSTR |= RCC_APB1RSTR_USART2RST;      \
    RCC->APB1RSTR &= ~RCC_APB1RSTR_USART2RST;     \
  } while (0)
#endif
#define LINK_DMA_CHANNEL 4u /* USART1_TX on DMA2 Stream7 and USART2_TX on DMA1 Stream6 */
#define LINK_AF 7u          /* AF7: USART1..3 */

/*
 * Baud rate register. DIV = round(f / baud) is USARTDIV * 16 with 16x oversampling and
 * USARTDIV * 8 with 8x; 8x (OVER8) only where 16x cannot reach the rate (baud > f / 16).
 * BRR holds DIV as 12.4 bits (16x) or as 12.3 bits with bit 3 clear (8x).
 */
#define LINK_OVER8 (SKIN_BOARD_BAUD > LINK_CLOCK_HZ / 16u)
#define LINK_DIV ((LINK_CLOCK_HZ + SKIN_BOARD_BAUD / 2u) / SKIN_BOARD_BAUD)
#define LINK_BRR (LINK_OVER8 ? (((LINK_DIV >> 3) << 4) | (LINK_DIV & 7u)) : LINK_DIV)
#define LINK_ACTUAL_BAUD (LINK_CLOCK_HZ / LINK_DIV)
_Static_assert(LINK_DIV >= 8u, "SKIN_BOARD_BAUD is above what the USART can generate");
/* Both ends of the line derive their rate from their own clocks; 1 % here leaves
 * the rest of an 8N1 receiver's tolerance (a few per cent) to the ST-LINK's side. */
_Static_assert((LINK_ACTUAL_BAUD > SKIN_BOARD_BAUD ? LINK_ACTUAL_BAUD - SKIN_BOARD_BAUD
                                                   : SKIN_BOARD_BAUD - LINK_ACTUAL_BAUD) *
                       100u <
                   SKIN_BOARD_BAUD,
               "SKIN_BOARD_BAUD cannot be generated within 1 % from the USART's clock");

volatile uint32_t nucleo_link_errors;
static volatile int busy;

/*
 * A DMA that stalled (bytes left past the transfer's bound, board_link_abort) is not trusted for
 * a while: the link sends by the CPU instead, byte by byte as TXE allows, and tries the DMA
 * again LINK_DMA_RETRY_US later. So a stream that never serves the USART again costs the CPU the
 * bytes' time, not the frames.
 */
#define LINK_DMA_RETRY_US 1000000u
/* A byte by the CPU: TXE within two byte times and 10 us, or the USART is stuck too. */
#define LINK_BYTE_BOUND_US (2u * (NUCLEO_LINK_BYTE_NS / 1000u + 1u) + 10u)
static int polled;
static int polled_stalled;
static uint32_t dma_retry_at;

void nucleo_link_init(void) {
  LINK_CLOCKS_ON();
  (void)RCC->AHB1ENR;
  nucleo_gpio_af(NUCLEO_LINK_TX, LINK_AF);
  nucleo_gpio_af(NUCLEO_LINK_RX, LINK_AF); /* unused for now; AF keeps it an input */

  LINK_USART->CR1 = 0u;
  LINK_USART->BRR = LINK_BRR;
  LINK_USART->CR2 = 0u;            /* 1 stop bit */
  LINK_USART->CR3 = USART_CR3_DMAT; /* TXE requests the DMA */
  LINK_USART->CR1 = USART_CR1_UE | USART_CR1_TE | (LINK_OVER8 ? USART_CR1_OVER8 : 0u);

  LINK_STREAM->CR = 0u;
  (void)skin_wait_bits(&LINK_STREAM->CR, DMA_SxCR_EN, 0u, 1000u);
  LINK_STREAM->PAR = (uint32_t)&LINK_USART->DR;
  /* Memory to peripheral, bytes, memory increments, high priority (below the ADC's). */
  LINK_STREAM->CR = (LINK_DMA_CHANNEL << DMA_SxCR_CHSEL_Pos) | DMA_SxCR_PL_1 | DMA_SxCR_MINC |
                    DMA_SxCR_DIR_0;
  LINK_STREAM->FCR = 0u;
  busy = 0;
}

void nucleo_link_poll(void) {} /* the DMA needs no CPU */

static void send_polled(const uint8_t *buf, uint32_t len) {
  for (uint32_t i = 0; i < len; i++) {
    if (skin_wait_flags(&LINK_USART->SR, USART_SR_TXE, 0u, LINK_BYTE_BOUND_US) !=
        SKIN_WAIT_DONE) {
      /* Not idle until the core's bound runs out and it aborts: a stall like the DMA's. */
      polled_stalled = 1;
      busy = 1;
      return;
    }
    LINK_USART->DR = buf[i];
  }
}

void board_link_send(const uint8_t *buf, uint32_t len) {
  if (len == 0u || len > 65535u) {
    return; /* NDTR is 16 bits; pins_check.c keeps a frame within it */
  }
  if (polled && (int32_t)(board_time_us32() - dma_retry_at) >= 0) {
    polled = 0;
  }
  if (polled) {
    send_polled(buf, len);
    return;
  }
  LINK_DMA->HIFCR = LINK_CLEAR;
  LINK_STREAM->M0AR = (uint32_t)buf;
  LINK_STREAM->NDTR = len;
  busy = 1;
  LINK_STREAM->CR |= DMA_SxCR_EN;
}

bool board_link_idle(void) {
  /* Done once the DMA has read the last byte into the USART: the buffer is free and the next
   * transfer may start while that byte is still on the line. */
  if (busy) {
    const uint32_t isr = LINK_DMA->HISR;
    if (isr & LINK_DONE) {
      if (isr & LINK_ERROR) {
        nucleo_link_errors++;
      }
      busy = 0;
    }
  }
  return !busy;
}

bool board_link_abort(void) {
  /* The core waited past the transfer's bound (skin_fw/scan.h). NDTR counts the bytes the DMA
   * has not yet handed to the USART. */
  const bool bytes_left =
      polled_stalled || (LINK_STREAM->NDTR != 0u && !(LINK_DMA->HISR & LINK_DONE));
  polled_stalled = 0;
  LINK_STREAM->CR &= ~DMA_SxCR_EN;
  (void)skin_wait_bits(&LINK_STREAM->CR, DMA_SxCR_EN, 0u, 1000u);
  LINK_DMA->HIFCR = LINK_CLEAR;
  if (bytes_left) {
    /* Stalled: the USART and the stream start again from their reset state, and the CPU sends
     * for a while. */
    LINK_RESET();
    nucleo_link_init();
    polled = 1;
    dma_retry_at = board_time_us32() + LINK_DMA_RETRY_US;
  }
  busy = 0;
  return bytes_left;
}
