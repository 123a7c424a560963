/* GPIO helpers: a pin id (SKIN_PIN) to its port, mode and alternate function. */
#include "nucleo.h"

GPIO_TypeDef *nucleo_gpio(uint32_t id) {
  /* GPIOA..GPIOD follow each other 0x400 apart on AHB1. */
  return (GPIO_TypeDef *)(GPIOA_BASE + 0x400u * (id / 16u));
}

void nucleo_gpio_init(void) {
  RCC->AHB1ENR |= RCC_AHB1ENR_GPIOAEN | RCC_AHB1ENR_GPIOBEN | RCC_AHB1ENR_GPIOCEN |
                  RCC_AHB1ENR_GPIODEN;
  (void)RCC->AHB1ENR; /* the read completes the enable before the first port access */
}

static void set_mode(uint32_t id, uint32_t mode) {
  GPIO_TypeDef *port = nucleo_gpio(id);
  const uint32_t shift = 2u * (id % 16u);
  port->MODER = (port->MODER & ~(3u << shift)) | (mode << shift);
}

void nucleo_gpio_output(uint32_t id, int high) {
  /* The level first, so the pin never drives the wrong one (a mux enable, for instance). */
  nucleo_gpio_write(id, high);
  GPIO_TypeDef *port = nucleo_gpio(id);
  const uint32_t pin = id % 16u;
  port->OTYPER &= ~(1u << pin);               /* push-pull */
  port->PUPDR &= ~(3u << (2u * pin));         /* no pull */
  port->OSPEEDR &= ~(3u << (2u * pin));       /* low speed: rows switch every few us */
  set_mode(id, 1u);
}

void nucleo_gpio_analog(uint32_t id) {
  GPIO_TypeDef *port = nucleo_gpio(id);
  port->PUPDR &= ~(3u << (2u * (id % 16u))); /* a pull would load the amplifier's output */
  set_mode(id, 3u);
}

void nucleo_gpio_af(uint32_t id, uint32_t af) {
  GPIO_TypeDef *port = nucleo_gpio(id);
  const uint32_t pin = id % 16u;
  const uint32_t shift = 4u * (pin % 8u);
  port->AFR[pin / 8u] = (port->AFR[pin / 8u] & ~(15u << shift)) | (af << shift);
  port->OSPEEDR |= 3u << (2u * pin); /* very high: clean edges at 1 Mbaud and above */
  set_mode(id, 2u);
}
